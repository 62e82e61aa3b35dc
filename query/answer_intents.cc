// AnswerBuilder intents that list or count: what is REL Y, how many, list, which robot, nearest.
#include <algorithm>
#include <map>
#include <unordered_set>
#include <utility>

#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "query/answer_builder.h"
#include "query/answer_text.h"

namespace loci::query {
namespace {

// Most anchor pairs tried for "what is between the Xs and the Ys".
constexpr size_t kMaxBetweenPairs = 2000;

std::string Phrase(RelationKind kind) { return std::string(RelationPhrase(kind)); }

}  // namespace

std::vector<RelationResult> AnswerBuilder::SubjectsRelated(
    const RelationClause& rel, const std::vector<int>& anchors, const std::vector<int>& anchors2,
    const RelationSearch::Mask* subjects) const {
  std::vector<RelationResult> found;
  if (rel.kind == RelationKind::kBetween) {
    size_t pairs = 0;
    const double max_span_m = 2.0 * opt_.relations.directional_max_m;
    for (int a : anchors) {
      for (int b : anchors2) {
        if (a == b || pairs >= kMaxBetweenPairs) continue;
        if ((index_.geom(a).centroid_g - index_.geom(b).centroid_g).norm() > max_span_m) continue;
        ++pairs;
        for (RelationResult& res : search_.SubjectsBetween(a, b, subjects)) {
          found.push_back(std::move(res));
        }
      }
    }
  } else {
    for (int a : anchors) {
      for (RelationResult& res : search_.SubjectsOf(rel.kind, a, subjects)) {
        found.push_back(std::move(res));
      }
    }
  }
  // One entry per subject: its most confident relation.
  std::stable_sort(
      found.begin(), found.end(),
      [](const RelationResult& a, const RelationResult& b) { return a.confidence > b.confidence; });
  std::vector<RelationResult> unique;
  std::unordered_set<int64_t> seen;
  for (RelationResult& f : found) {
    if (!seen.insert(f.subject_id).second) continue;
    unique.push_back(std::move(f));
  }
  return unique;
}

std::string AnswerBuilder::GroupedRelationAnswer(const RelationClause& rel,
                                                 const std::vector<RelationResult>& unique,
                                                 AskResult* r) const {
  // Group the subjects by their anchor (pair), groups in order of their best relation.
  std::vector<std::pair<std::pair<int64_t, int64_t>, std::vector<std::string>>> groups;
  for (const RelationResult& u : unique) {
    const int s = *index_.IndexOfId(u.subject_id);
    const MapObject& o = index_.object(s);
    if (r->objects.size() < opt_.max_result_objects) {
      AddObject(s, r);
      r->relations.push_back(u);
      search_.WithEvidence(&r->relations.back());
    }
    const std::pair<int64_t, int64_t> key{u.anchor_id, u.anchor2_id};
    auto it =
        std::find_if(groups.begin(), groups.end(), [&](const auto& g) { return g.first == key; });
    if (it == groups.end()) {
      if (groups.size() > opt_.sentence_max_items) continue;  // only counted below
      groups.push_back({key, {}});
      it = groups.end() - 1;
    }
    it->second.push_back(
        absl::StrCat(CountedClass(index_.vocabulary(), o.class_name, 1), " (#", o.id, ")"));
  }
  std::vector<std::string> parts;
  for (size_t g = 0; g < groups.size() && g < opt_.sentence_max_items; ++g) {
    const auto& [key, items] = groups[g];
    std::string anchor = ObjectRef(index_.object(*index_.IndexOfId(key.first)));
    if (key.second != 0) {
      absl::StrAppend(&anchor, " and ", ObjectRef(index_.object(*index_.IndexOfId(key.second))));
    }
    parts.push_back(absl::StrCat(Phrase(rel.kind), " ", anchor,
                                 items.size() == 1 ? " there is " : " there are ",
                                 JoinItems(items, opt_.sentence_max_items)));
  }
  std::string answer = Capitalize(absl::StrJoin(parts, "; "));
  if (groups.size() > opt_.sentence_max_items) {
    absl::StrAppend(&answer, "; and more ", Phrase(rel.kind), " other ", PhrasePlural(*rel.anchor));
  }
  if (groups.size() > 1) {
    absl::StrAppend(&answer, " (", unique.size(), unique.size() == 1 ? " object)" : " objects)");
  }
  return absl::StrCat(answer, ".");
}

void AnswerBuilder::WhatRelation(const ParsedQuery& q, AskResult* r) const {
  const RelationClause& rel = *q.relation;
  RelationSearch::Mask subject_mask;
  if (q.target && !q.target->any()) subject_mask = search_.MakeMask(Matching(*q.target));
  const RelationSearch::Mask* subjects = subject_mask.empty() ? nullptr : &subject_mask;
  const std::vector<int> anchors = Matching(*rel.anchor);
  if (NoneOf(*rel.anchor, anchors, r)) return;
  std::vector<int> anchors2;
  if (rel.kind == RelationKind::kBetween) {
    anchors2 = Matching(*rel.anchor2);
    if (NoneOf(*rel.anchor2, anchors2, r)) return;
  }
  const std::vector<RelationResult> unique = SubjectsRelated(rel, anchors, anchors2, subjects);
  r->count = static_cast<int64_t>(unique.size());
  r->yes = !unique.empty();
  if (!unique.empty()) {
    r->answer = GroupedRelationAnswer(rel, unique, r);
    return;
  }
  const std::string what = q.target && !q.target->any() ? PhraseNoun(*q.target) : "";
  r->answer = absl::StrCat(what.empty() ? "Nothing" : absl::StrCat("No ", what), " is ",
                           anchors.size() > 1
                               ? absl::StrCat(Phrase(rel.kind), " any of the ", anchors.size(), " ",
                                              PhrasePlural(*rel.anchor))
                               : absl::StrCat(Phrase(rel.kind), " ", AnchorText(rel, anchors)),
                           ".");
}

void AnswerBuilder::Count(const ParsedQuery& q, AskResult* r) const {
  const std::vector<int> targets = Matching(*q.target);
  const std::string noun = PhraseNoun(*q.target);
  int64_t n = static_cast<int64_t>(targets.size());
  std::string tail;
  if (q.relation && !targets.empty()) {
    const RelationClause& rel = *q.relation;
    const std::vector<int> anchors = Matching(*rel.anchor);
    const std::vector<RelationResult> holding = Holding(targets, rel);
    n = static_cast<int64_t>(holding.size());
    for (const RelationResult& h : holding) {
      if (r->objects.size() >= opt_.max_result_objects) break;
      AddObject(*index_.IndexOfId(h.subject_id), r);
      r->relations.push_back(h);
    }
    tail =
        absl::StrCat(" ", Phrase(rel.kind), " ",
                     anchors.empty() ? PhraseWithArticle(*rel.anchor) : AnchorText(rel, anchors));
  } else {
    if (q.relation) {
      tail =
          absl::StrCat(" ", Phrase(q.relation->kind), " ", PhraseWithArticle(*q.relation->anchor));
    }
    for (int i : targets) {
      if (r->objects.size() >= opt_.max_result_objects) break;
      AddObject(i, r);
    }
  }
  r->count = n;
  r->yes = n > 0;
  const std::string counted = n == 1   ? absl::StrCat("1 ", noun)
                              : n == 0 ? absl::StrCat("no ", PhrasePlural(*q.target))
                                       : absl::StrCat(n, " ", PhrasePlural(*q.target));
  r->answer = absl::StrCat(n == 1 ? "There is " : "There are ", counted, tail, ".");
}

void AnswerBuilder::List(const ParsedQuery& q, AskResult* r) const {
  ObjectPhrase any;
  const ObjectPhrase& phrase = q.target ? *q.target : any;
  const std::vector<int> targets = Matching(phrase);
  if (NoneOf(phrase, targets, r)) return;
  r->count = static_cast<int64_t>(targets.size());
  r->yes = true;
  for (int i : targets) {
    if (r->objects.size() >= opt_.max_result_objects) break;
    AddObject(i, r);
  }
  if (phrase.any()) {
    std::vector<std::pair<int, std::string>> by_count;
    for (const auto& [c, n] : index_.class_counts()) by_count.push_back({-n, c});
    std::sort(by_count.begin(), by_count.end());
    std::vector<std::string> items;
    for (const auto& [neg, c] : by_count) {
      items.push_back(CountedClass(index_.vocabulary(), c, -neg));
    }
    r->answer = absl::StrCat("The map has ", targets.size(),
                             targets.size() == 1 ? " object: " : " objects: ",
                             JoinItems(items, std::max<size_t>(opt_.sentence_max_items, 12)), ".");
    return;
  }
  std::vector<std::string> items;
  for (int i : targets) {
    if (items.size() >= opt_.sentence_max_items) break;
    items.push_back(absl::StrCat("#", index_.object(i).id, " at ", Position(index_.object(i))));
  }
  if (targets.size() > items.size()) {
    items.push_back(absl::StrCat(targets.size() - items.size(), " not listed"));
  }
  r->answer = absl::StrCat(
      "I know ",
      CountedClass(index_.vocabulary(), PhraseNoun(phrase), static_cast<int64_t>(targets.size())),
      ": ", JoinItems(items, items.size()), ".");
}

void AnswerBuilder::WhichRobot(const ParsedQuery& q, AskResult* r) const {
  const std::vector<int> targets = Matching(*q.target);
  if (NoneOf(*q.target, targets, r)) return;
  // Latest last_seen (or earliest first_seen for "first").
  int best = targets[0];
  for (int i : targets) {
    const MapObject& o = index_.object(i);
    const MapObject& b = index_.object(best);
    if (q.first_seen ? o.first_seen_ns < b.first_seen_ns : o.last_seen_ns > b.last_seen_ns)
      best = i;
  }
  const MapObject& o = index_.object(best);
  AddObject(best, r);
  r->count = static_cast<int64_t>(targets.size());
  // `robots` is kept in order of first observation (MapObject), so its front saw it first.
  const std::string robot = q.first_seen            ? (o.robots.empty() ? "" : o.robots.front())
                            : !o.last_robot.empty() ? o.last_robot
                            : o.robots.empty()      ? ""
                                                    : o.robots.back();
  if (robot.empty()) {
    r->yes = false;
    r->answer = absl::StrCat("No robot name is recorded for ", ObjectRef(o), ".");
    return;
  }
  r->yes = true;
  const int64_t t_ns = q.first_seen ? o.first_seen_ns : o.last_seen_ns;
  std::string when;
  if (now_ns_ > 0 && t_ns > 0) when = absl::StrCat(", ", Duration(now_ns_ - t_ns), " ago");
  r->answer = absl::StrCat("The ", q.first_seen ? "first" : "last", " robot to see ", ObjectRef(o),
                           " was ", robot, when);
  if (o.robots.size() > 1) {
    absl::StrAppend(&r->answer, " (seen by ", JoinItems(o.robots, o.robots.size()), ")");
  }
  absl::StrAppend(&r->answer, ".");
}

void AnswerBuilder::Nearest(const ParsedQuery& q, AskResult* r) const {
  const std::vector<int> targets = Matching(*q.target);
  if (NoneOf(*q.target, targets, r)) return;
  const RelationClause& rel = *q.relation;
  std::vector<int> anchors;
  if (rel.anchor) {
    anchors = Matching(*rel.anchor);
    if (NoneOf(*rel.anchor, anchors, r)) return;
  } else if (search_.viewpoint() == nullptr) {
    r->status = absl::FailedPreconditionError("no viewpoint");
    r->answer = absl::StrCat(
        "Nearest to what? No robot pose is known; ask \"where is the "
        "nearest ",
        PhraseNoun(*q.target), " to the ...\".");
    return;
  }
  auto n = search_.NearestPair(targets, rel.anchor ? &anchors : nullptr);
  if (!n) {  // the only target is the anchor itself
    r->yes = false;
    r->answer = absl::StrCat("There is no other ", PhraseNoun(*q.target), ".");
    return;
  }
  const MapObject& o = index_.object(n->subject);
  AddObject(n->subject, r);
  r->count = 1;
  r->yes = true;
  RelationResult res;
  res.kind = RelationKind::kNearest;
  res.subject_id = o.id;
  res.anchor_id = n->anchor >= 0 ? index_.object(n->anchor).id : 0;
  res.holds = true;
  res.confidence = 1.0;
  res.distance_m = n->gap_m;
  const std::string to = n->anchor >= 0                       ? ObjectRef(index_.object(n->anchor))
                         : search_.viewpoint()->robot.empty() ? std::string("the viewer")
                                                              : search_.viewpoint()->robot;
  res.evidence = absl::StrFormat("boxes %.2f m apart, nearest of %d %s", n->gap_m, targets.size(),
                                 PhrasePlural(*q.target));
  r->relations.push_back(res);
  r->answer = absl::StrFormat("The nearest %s to %s is #%d, %.2f m away, at %s.",
                              PhraseNoun(*q.target), to, o.id, n->gap_m, Position(o));
  const std::string seen = SeenPhrase(o, now_ns_);
  if (!seen.empty()) r->answer.insert(r->answer.size() - 1, ", " + seen);
}

}  // namespace loci::query
