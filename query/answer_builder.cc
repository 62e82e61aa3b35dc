#include "query/answer_builder.h"

#include <algorithm>
#include <map>
#include <unordered_map>

#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "query/answer_text.h"

namespace loci::query {
namespace {

std::string Phrase(RelationKind kind) { return std::string(RelationPhrase(kind)); }

}  // namespace

void AnswerBuilder::Answer(const ParsedQuery& q, AskResult* r) const {
  if (q.relation && NeedsViewpoint(q.relation->kind) && search_.viewpoint() == nullptr) {
    r->status = absl::FailedPreconditionError("no viewpoint");
    r->answer = absl::StrCat("I cannot tell what is ", Phrase(q.relation->kind),
                             " something without a viewpoint: no robot pose is known.");
    return;
  }
  switch (q.intent) {
    case Intent::kWhere:
      Where(q, r);
      break;
    case Intent::kWhatRelation:
      WhatRelation(q, r);
      break;
    case Intent::kExists:
    case Intent::kCheckRelation:
      Exists(q, r);
      break;
    case Intent::kCount:
      Count(q, r);
      break;
    case Intent::kList:
      List(q, r);
      break;
    case Intent::kWhichRobot:
      WhichRobot(q, r);
      break;
    case Intent::kNearest:
      Nearest(q, r);
      break;
    case Intent::kChanges:
      Changes(q, r);
      break;
    case Intent::kWhereBefore:
      WhereBefore(q, r);
      break;
  }
}

std::vector<int> AnswerBuilder::Matching(const ObjectPhrase& phrase) const {
  std::vector<int> out;
  if (phrase.id) {
    if (auto i = index_.IndexOfId(*phrase.id); i && index_.eligible(*i)) out.push_back(*i);
    return out;
  }
  if (phrase.any()) {
    for (size_t i = 0; i < index_.size(); ++i) {
      if (index_.eligible(i)) out.push_back(static_cast<int>(i));
    }
    return out;
  }
  for (int i : index_.OfClasses(phrase.classes)) {
    if (index_.eligible(i)) out.push_back(i);
  }
  return out;
}

std::string AnswerBuilder::PhraseNoun(const ObjectPhrase& p) const {
  if (p.id) return absl::StrCat("object #", *p.id);
  if (p.any()) return "object";
  return absl::StrJoin(p.classes, " or ");
}

std::string AnswerBuilder::PhrasePlural(const ObjectPhrase& p) const {
  if (p.id) return absl::StrCat("object #", *p.id);
  if (p.any()) return "objects";
  std::vector<std::string> plurals;
  for (const std::string& c : p.classes) plurals.push_back(index_.vocabulary().Plural(c));
  return absl::StrJoin(plurals, " or ");
}

std::string AnswerBuilder::PhraseWithArticle(const ObjectPhrase& p) const {
  if (p.id) return absl::StrCat("object #", *p.id);
  const std::string noun = PhraseNoun(p);
  return CountedClass(index_.vocabulary(), noun, 1);
}

void AnswerBuilder::AddObject(int i, AskResult* r) const {
  if (r->objects.size() < opt_.max_result_objects) r->objects.push_back(index_.object(i));
}

bool AnswerBuilder::NoneOf(const ObjectPhrase& phrase, const std::vector<int>& matches,
                           AskResult* r) const {
  if (!matches.empty()) return false;
  if (phrase.id) {
    r->answer = absl::StrCat("There is no object #", *phrase.id, " in the map.");
  } else if (phrase.any()) {
    r->answer = "The map has no objects yet.";
  } else {
    r->answer = absl::StrCat("I have not seen any ", PhrasePlural(phrase), ".");
  }
  r->yes = false;
  r->count = 0;
  return true;
}

std::string AnswerBuilder::RelText(const RelationResult& rel) const {
  std::string s(Phrase(rel.kind));
  if (auto a = index_.IndexOfId(rel.anchor_id)) {
    absl::StrAppend(&s, " ", ObjectRef(index_.object(*a)));
  } else if (rel.kind == RelationKind::kNearest) {
    absl::StrAppend(&s, " the viewer");
  }
  if (rel.anchor2_id != 0) {
    if (auto b = index_.IndexOfId(rel.anchor2_id)) {
      absl::StrAppend(&s, " and ", ObjectRef(index_.object(*b)));
    }
  }
  return s;
}

std::string AnswerBuilder::Describe(int i, const std::optional<RelationResult>& support) const {
  std::string s = ObjectRef(index_.object(i));
  if (support) absl::StrAppend(&s, " ", RelText(*support));
  return s;
}

std::vector<RelationResult> AnswerBuilder::Holding(const std::vector<int>& targets,
                                                   const RelationClause& rel) const {
  std::vector<RelationResult> out;
  if (!rel.anchor) return out;
  const std::vector<int> anchors = Matching(*rel.anchor);
  const RelationSearch::Mask target_mask = search_.MakeMask(targets);
  if (rel.kind != RelationKind::kBetween && anchors.size() < targets.size()) {
    // Fewer anchors than targets: search around each anchor instead of each target.
    std::unordered_map<int64_t, size_t> slot;  // subject id -> position in `out`
    for (int a : anchors) {
      for (RelationResult& res : search_.SubjectsOf(rel.kind, a, &target_mask)) {
        auto [it, inserted] = slot.try_emplace(res.subject_id, out.size());
        if (inserted) {
          out.push_back(std::move(res));
        } else if (res.confidence > out[it->second].confidence) {
          out[it->second] = std::move(res);
        }
      }
    }
  } else {
    const RelationSearch::Mask anchor_mask = search_.MakeMask(anchors);
    RelationSearch::Mask anchor2_mask;
    if (rel.anchor2) anchor2_mask = search_.MakeMask(Matching(*rel.anchor2));
    for (int t : targets) {
      if (auto res =
              search_.BestTo(rel.kind, t, anchor_mask, rel.anchor2 ? &anchor2_mask : nullptr)) {
        out.push_back(std::move(*res));
      }
    }
  }
  std::stable_sort(out.begin(), out.end(), [](const RelationResult& a, const RelationResult& b) {
    if (a.confidence != b.confidence) return a.confidence > b.confidence;
    return a.subject_id < b.subject_id;
  });
  for (size_t k = 0; k < out.size() && k < opt_.max_result_objects; ++k) {
    search_.WithEvidence(&out[k]);
  }
  return out;
}

std::string AnswerBuilder::Instead(const std::vector<int>& targets, const std::vector<int>& anchors,
                                   const RelationClause& rel, AskResult* r) const {
  std::vector<int> order = targets;
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return index_.object(a).confidence > index_.object(b).confidence;
  });
  const bool vertical = rel.kind == RelationKind::kOn || rel.kind == RelationKind::kUnder ||
                        rel.kind == RelationKind::kAbove || rel.kind == RelationKind::kBelow ||
                        rel.kind == RelationKind::kInside;
  if (!vertical && !anchors.empty()) {
    if (auto n = search_.NearestPair(targets, &anchors)) {
      AddObject(n->subject, r);
      return absl::StrFormat("the nearest is %s, %.2f m from %s",
                             ObjectRef(index_.object(n->subject)), n->gap_m,
                             ObjectRef(index_.object(n->anchor)));
    }
  }
  std::vector<std::string> items;
  for (int i : order) {
    if (items.size() >= opt_.sentence_max_items) break;
    const auto support = search_.Support(i);
    if (support) r->relations.push_back(*support);
    AddObject(i, r);
    items.push_back(absl::StrCat(Describe(i, support), " at ", Position(index_.object(i))));
  }
  if (order.size() > items.size())
    items.push_back(absl::StrCat(order.size() - items.size(), " more"));
  return absl::StrCat("I found ", JoinItems(items, items.size()));
}

std::string AnswerBuilder::OneSentence(int i, const std::optional<RelationResult>& rel) const {
  const MapObject& o = index_.object(i);
  std::string s = absl::StrCat(Capitalize(ObjectRef(o)), " is");
  if (rel) absl::StrAppend(&s, " ", RelText(*rel));
  absl::StrAppend(&s, " at ", Position(o));
  const std::string seen = SeenPhrase(o, now_ns_);
  if (!seen.empty()) absl::StrAppend(&s, ", ", seen);
  return absl::StrCat(s, ".");
}

std::string AnswerBuilder::AnchorText(const RelationClause& rel,
                                      const std::vector<int>& anchors) const {
  if (!rel.anchor) return "you";
  auto text = [&](const ObjectPhrase& p, size_t n) {
    if (n == 1 && !rel.anchor2) return ObjectRef(index_.object(anchors[0]));
    return p.plural ? absl::StrCat("the ", PhrasePlural(p)) : PhraseWithArticle(p);
  };
  std::string a = text(*rel.anchor, anchors.size());
  if (rel.anchor2) absl::StrAppend(&a, " and ", text(*rel.anchor2, 2));
  return a;
}

void AnswerBuilder::Where(const ParsedQuery& q, AskResult* r) const {
  std::vector<int> targets = Matching(*q.target);
  if (NoneOf(*q.target, targets, r)) return;
  std::stable_sort(targets.begin(), targets.end(), [&](int a, int b) {
    const MapObject& oa = index_.object(a);
    const MapObject& ob = index_.object(b);
    if (oa.confidence != ob.confidence) return oa.confidence > ob.confidence;
    return oa.last_seen_ns > ob.last_seen_ns;
  });
  if (!q.relation) {
    r->yes = true;
    r->count = static_cast<int64_t>(targets.size());
    std::vector<std::string> items;
    for (int i : targets) {
      if (r->objects.size() >= opt_.max_result_objects) break;
      const auto support = search_.Support(i);
      if (support) r->relations.push_back(*support);
      AddObject(i, r);
      if (targets.size() == 1) {
        r->answer = OneSentence(i, support);
        return;
      }
      std::string item = absl::StrCat("#", index_.object(i).id);
      if (support) absl::StrAppend(&item, " ", RelText(*support));
      items.push_back(absl::StrCat(item, " at ", Position(index_.object(i))));
    }
    if (targets.size() > items.size()) {
      items.push_back(absl::StrCat(targets.size() - items.size(), " not listed"));
    }
    r->answer = absl::StrCat("I know ",
                             CountedClass(index_.vocabulary(), PhraseNoun(*q.target),
                                          static_cast<int64_t>(targets.size())),
                             ": ", JoinItems(items, opt_.sentence_max_items), ".");
    return;
  }
  const RelationClause& rel = *q.relation;
  const std::vector<RelationResult> holding = Holding(targets, rel);
  const std::vector<int> anchors = rel.anchor ? Matching(*rel.anchor) : std::vector<int>{};
  if (holding.empty()) {
    r->yes = false;
    r->count = 0;
    if (anchors.empty()) {
      r->answer = absl::StrCat("I have not seen any ", PhrasePlural(*rel.anchor), ", so no ",
                               PhraseNoun(*q.target), " is ", Phrase(rel.kind), " one; ",
                               Instead(targets, anchors, rel, r), ".");
    } else {
      r->answer =
          absl::StrCat("No ", PhraseNoun(*q.target), " is ", Phrase(rel.kind), " ",
                       AnchorText(rel, anchors), "; ", Instead(targets, anchors, rel, r), ".");
    }
    return;
  }
  r->yes = true;
  r->count = static_cast<int64_t>(holding.size());
  std::vector<std::string> items;
  for (const RelationResult& h : holding) {
    if (r->objects.size() >= opt_.max_result_objects) break;
    const int s = *index_.IndexOfId(h.subject_id);
    AddObject(s, r);
    r->relations.push_back(h);
    items.push_back(absl::StrCat(Describe(s, h), " at ", Position(index_.object(s))));
  }
  if (holding.size() == 1) {
    r->answer = OneSentence(*index_.IndexOfId(holding[0].subject_id), holding[0]);
  } else {
    r->answer = absl::StrCat(holding.size(), " ", PhrasePlural(*q.target), " are ",
                             Phrase(rel.kind), " ", AnchorText(rel, anchors), ": ",
                             JoinItems(items, opt_.sentence_max_items), ".");
  }
}

void AnswerBuilder::Exists(const ParsedQuery& q, AskResult* r) const {
  const std::vector<int> targets = Matching(*q.target);
  if (targets.empty()) {
    NoneOf(*q.target, targets, r);
    r->answer =
        absl::StrCat("No, ", r->answer.rfind("I ", 0) == 0 ? r->answer : Uncapitalize(r->answer));
    return;
  }
  if (!q.relation) {
    r->yes = true;
    r->count = static_cast<int64_t>(targets.size());
    std::vector<std::string> items;
    for (int i : targets) {
      if (r->objects.size() >= opt_.max_result_objects) break;
      AddObject(i, r);
      items.push_back(
          absl::StrCat(ObjectRef(index_.object(i)), " at ", Position(index_.object(i))));
    }
    r->answer = absl::StrCat("Yes, there ", targets.size() == 1 ? "is " : "are ",
                             CountedClass(index_.vocabulary(), PhraseNoun(*q.target),
                                          static_cast<int64_t>(targets.size())),
                             ": ", JoinItems(items, opt_.sentence_max_items), ".");
    return;
  }
  const RelationClause& rel = *q.relation;
  const std::vector<int> anchors = rel.anchor ? Matching(*rel.anchor) : std::vector<int>{};
  const std::vector<int> anchors2 = rel.anchor2 ? Matching(*rel.anchor2) : std::vector<int>{};
  if (rel.anchor && (anchors.empty() || (rel.anchor2 && anchors2.empty()))) {
    const ObjectPhrase& missing = anchors.empty() ? *rel.anchor : *rel.anchor2;
    r->yes = false;
    r->answer = absl::StrCat("No, I have not seen any ", PhrasePlural(missing), "; ",
                             Instead(targets, {}, rel, r), ".");
    return;
  }
  const std::vector<RelationResult> holding = Holding(targets, rel);
  r->count = static_cast<int64_t>(holding.size());
  if (holding.empty()) {
    r->yes = false;
    r->answer =
        absl::StrCat("No, no ", PhraseNoun(*q.target), " is ", Phrase(rel.kind), " ",
                     AnchorText(rel, anchors), "; ", Instead(targets, anchors, rel, r), ".");
    return;
  }
  r->yes = true;
  std::vector<std::string> items;
  for (const RelationResult& h : holding) {
    if (r->objects.size() >= opt_.max_result_objects) break;
    const int s = *index_.IndexOfId(h.subject_id);
    AddObject(s, r);
    r->relations.push_back(h);
    items.push_back(Describe(s, h));
  }
  if (holding.size() == 1) {
    const RelationResult& h = holding[0];
    r->answer = absl::StrCat("Yes, ", ObjectRef(index_.object(*index_.IndexOfId(h.subject_id))),
                             " is ", RelText(h), ": ", h.evidence, ".");
  } else {
    r->answer = absl::StrCat("Yes, ", holding.size(), " ", PhrasePlural(*q.target), " are ",
                             Phrase(rel.kind), " ", AnchorText(rel, anchors), ": ",
                             JoinItems(items, opt_.sentence_max_items), ".");
  }
}

}  // namespace loci::query
