// Answers about the map over time, from the objects' place histories (MapObject::history).
#include <algorithm>
#include <ctime>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "query/answer_builder.h"
#include "query/answer_text.h"

namespace loci::query {
namespace {

using Kind = ObjectPlaceChange::Kind;
using Filter = ParsedQuery::ChangeFilter;

constexpr int64_t kDayNs = 86'400'000'000'000;
constexpr size_t kMaxListed = 12;  // changes spelled out in one sentence

std::string At(const Eigen::Vector3d& p_m) {
  return absl::StrFormat("(%.2f, %.2f, %.2f) m", p_m.x(), p_m.y(), p_m.z());
}

struct Entry {
  int64_t t_ns = 0;
  const MapObject* object = nullptr;
  const ObjectPlaceChange* change = nullptr;
};

bool Wanted(Filter filter, Kind kind) {
  switch (filter) {
    case Filter::kAll: return true;
    case Filter::kNew: return kind == Kind::kAppeared;
    case Filter::kMoved: return kind == Kind::kMoved;
    case Filter::kGone: return kind == Kind::kRemoved;
  }
  return true;
}

const char* FilterNoun(Filter filter) {
  switch (filter) {
    case Filter::kAll: return "changed";
    case Filter::kNew: return "is new";
    case Filter::kMoved: return "moved";
    case Filter::kGone: return "is gone";
  }
  return "changed";
}

std::string EntryText(const Entry& e, int64_t now_ns) {
  const MapObject& o = *e.object;
  const ObjectPlaceChange& c = *e.change;
  const std::string ago = absl::StrCat(Duration(now_ns - e.t_ns), " ago");
  switch (c.kind) {
    case Kind::kAppeared:
      return absl::StrCat(ObjectRef(o), " appeared at ", At(c.centroid_m), " ", ago);
    case Kind::kMoved:
      return absl::StrFormat("%s moved %.2f m from %s to %s %s", ObjectRef(o),
                             (c.centroid_m - c.from_m).norm(), At(c.from_m), At(c.centroid_m),
                             ago);
    case Kind::kRemoved:
      return absl::StrCat(ObjectRef(o), " went from ", At(c.from_m), " (", ago, ", its place seen ",
                          "empty in ", c.evidence_keyframe_ids.size(), " keyframes)");
  }
  return "";
}

// "2026-12-05" (UTC).
std::string DateText(int64_t t_ns) {
  const std::time_t t = static_cast<std::time_t>(t_ns / 1'000'000'000);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char out[16];
  std::strftime(out, sizeof(out), "%Y-%m-%d", &tm);
  return out;
}

// The newest time any history or sighting shows: "now" when the caller gave none.
int64_t NewestNs(const MapIndex& index) {
  int64_t newest = 0;
  auto scan = [&](const MapObject& o) {
    newest = std::max(newest, o.last_seen_ns);
    for (const ObjectPlaceChange& c : o.history) newest = std::max(newest, c.t_ns);
  };
  for (size_t i = 0; i < index.size(); ++i) scan(index.object(static_cast<int>(i)));
  for (const MapObject& o : index.removed()) scan(o);
  return newest;
}

bool Names(const ObjectPhrase& phrase, const MapObject& o) {
  if (phrase.id) return *phrase.id == o.id;
  return phrase.any() ||
         std::find(phrase.classes.begin(), phrase.classes.end(), o.class_name) !=
             phrase.classes.end();
}

}  // namespace

void AnswerBuilder::Changes(const ParsedQuery& q, AskResult* r) const {
  const int64_t now_ns = now_ns_ > 0 ? now_ns_ : NewestNs(index_);
  const int64_t since_ns = q.since_t_ns     ? *q.since_t_ns
                           : q.since_s      ? now_ns - static_cast<int64_t>(*q.since_s * 1e9)
                                            : now_ns - kDayNs;
  std::vector<Entry> entries;
  auto collect = [&](const MapObject& o) {
    for (const ObjectPlaceChange& c : o.history) {
      if (c.t_ns > since_ns && Wanted(q.changes, c.kind)) entries.push_back({c.t_ns, &o, &c});
    }
  };
  for (size_t i = 0; i < index_.size(); ++i) {
    if (index_.eligible(static_cast<int>(i))) collect(index_.object(static_cast<int>(i)));
  }
  for (const MapObject& o : index_.removed()) collect(o);
  std::sort(entries.begin(), entries.end(),
            [](const Entry& a, const Entry& b) { return a.t_ns > b.t_ns; });  // newest first
  const std::string window = q.since_t_ns ? absl::StrCat("since ", DateText(*q.since_t_ns))
                             : q.since_s
                                 ? absl::StrCat("in the last ", Duration(now_ns - since_ns))
                                 : std::string("in the last day");
  r->count = static_cast<int64_t>(entries.size());
  r->yes = !entries.empty();
  if (entries.empty()) {
    r->answer = absl::StrCat("Nothing ", FilterNoun(q.changes), " ", window, ".");
    return;
  }
  std::vector<std::string> items;
  for (const Entry& e : entries) {
    items.push_back(EntryText(e, now_ns));
    const bool listed = std::any_of(r->objects.begin(), r->objects.end(),
                                    [&](const MapObject& o) { return o.id == e.object->id; });
    if (!listed && r->objects.size() < opt_.max_result_objects) r->objects.push_back(*e.object);
  }
  r->answer = absl::StrCat(Capitalize(window), ", ", entries.size(),
                           entries.size() == 1 ? " change: " : " changes: ",
                           JoinItems(items, kMaxListed), ".");
}

void AnswerBuilder::WhereBefore(const ParsedQuery& q, AskResult* r) const {
  const int64_t now_ns = now_ns_ > 0 ? now_ns_ : NewestNs(index_);
  std::vector<const MapObject*> named;
  for (size_t i = 0; i < index_.size(); ++i) {
    const MapObject& o = index_.object(static_cast<int>(i));
    if (index_.eligible(static_cast<int>(i)) && Names(*q.target, o)) named.push_back(&o);
  }
  for (const MapObject& o : index_.removed()) {
    if (Names(*q.target, o)) named.push_back(&o);
  }
  if (named.empty()) {
    r->yes = false;
    r->answer = absl::StrCat("I have no ", PhraseNoun(*q.target), " in the map, now or before.");
    return;
  }
  std::vector<std::string> sentences;
  int moved = 0;
  for (const MapObject* o : named) {
    const auto last_move = std::find_if(o->history.rbegin(), o->history.rend(), [](const auto& c) {
      return c.kind != Kind::kAppeared;
    });
    if (last_move == o->history.rend()) continue;
    ++moved;
    r->objects.push_back(*o);
    const std::string ago = absl::StrCat(Duration(now_ns - last_move->t_ns), " ago");
    sentences.push_back(
        o->removed_t_ns != 0
            ? absl::StrCat(Capitalize(ObjectRef(*o)), " was at ", At(last_move->from_m),
                           " until ", ago, "; its place was then seen empty and it was not seen since.")
            : absl::StrCat(Capitalize(ObjectRef(*o)), " was at ", At(last_move->from_m),
                           " until ", ago, "; it is now at ", Position(*o), "."));
  }
  r->count = moved;
  r->yes = moved > 0;
  if (moved == 0) {
    r->answer = named.size() == 1
                    ? absl::StrCat(Capitalize(ObjectRef(*named.front())),
                                   " has not moved since it appeared; it is at ",
                                   Position(*named.front()), ".")
                    : absl::StrCat("No ", PhraseNoun(*q.target),
                                   " has moved since it appeared; each is where it was first seen.");
    for (const MapObject* o : named) r->objects.push_back(*o);
    return;
  }
  r->answer = absl::StrJoin(sentences, " ");
}

}  // namespace loci::query
