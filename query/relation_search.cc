#include "query/relation_search.h"

#include <algorithm>
#include <limits>

namespace loci::query {
namespace {

// Brute force over all subject x anchor pairs below this many pairs.
constexpr size_t kBrutePairs = 40000;

bool Better(const RelationResult& a, const RelationResult& b) {
  if (a.confidence != b.confidence) return a.confidence > b.confidence;
  return a.subject_id < b.subject_id;
}

}  // namespace

RelationSearch::Mask RelationSearch::MakeMask(const std::vector<int>& indices) const {
  Mask mask(index_.size(), 0);
  for (int i : indices) mask[i] = 1;
  return mask;
}

void RelationSearch::WithEvidence(RelationResult* r) const {
  const auto s = index_.IndexOfId(r->subject_id);
  const auto a = index_.IndexOfId(r->anchor_id);
  if (!s || !a || !r->evidence.empty()) return;
  if (r->kind == RelationKind::kBetween) {
    const auto b = index_.IndexOfId(r->anchor2_id);
    if (b) *r = eval_.Between(index_.geom(*s), index_.geom(*a), index_.geom(*b), true);
    return;
  }
  if (r->kind == RelationKind::kNearest) return;
  const RelationKind kind = r->kind;
  *r = Evaluate(kind, *s, *a, true);
}

RelationResult RelationSearch::Evaluate(RelationKind kind, int subject, int anchor,
                                        bool evidence) const {
  const ObjectGeom& s = index_.geom(subject);
  const ObjectGeom& a = index_.geom(anchor);
  RelationResult r = eval_.Evaluate(kind, s, a, viewpoint_, evidence);
  // Everyday meaning: a book on the table is also above it; under and below overlap.
  RelationKind alt = kind;
  if (kind == RelationKind::kAbove) alt = RelationKind::kOn;
  if (kind == RelationKind::kUnder) alt = RelationKind::kBelow;
  if (kind == RelationKind::kBelow) alt = RelationKind::kUnder;
  if (alt != kind && !r.holds) {
    RelationResult r2 = eval_.Evaluate(alt, s, a, viewpoint_, evidence);
    if (r2.holds) {
      r2.kind = kind;
      return r2;
    }
  }
  return r;
}

std::vector<RelationResult> RelationSearch::SubjectsOf(RelationKind kind, int anchor,
                                                       const Mask* subjects) const {
  std::vector<RelationResult> out;
  const ObjectGeom& a = index_.geom(anchor);
  for (int i : index_.Candidates(a.box, eval_.SearchRadius(kind, a))) {
    if (i == anchor || !index_.eligible(i) || (subjects && !(*subjects)[i])) continue;
    RelationResult r = Evaluate(kind, i, anchor, false);
    if (r.holds) out.push_back(std::move(r));
  }
  std::sort(out.begin(), out.end(), Better);
  return out;
}

std::vector<RelationResult> RelationSearch::SubjectsBetween(int a, int b,
                                                            const Mask* subjects) const {
  std::vector<RelationResult> out;
  const ObjectGeom& ga = index_.geom(a);
  const ObjectGeom& gb = index_.geom(b);
  BoxG span;
  span.min = ga.box.min.cwiseMin(gb.box.min);
  span.max = ga.box.max.cwiseMax(gb.box.max);
  const double radius = std::max(eval_.options().between_min_m, 1.0);
  for (int i : index_.Candidates(span, radius)) {
    if (i == a || i == b || !index_.eligible(i) || (subjects && !(*subjects)[i])) continue;
    RelationResult r = eval_.Between(index_.geom(i), ga, gb, false);
    if (r.holds) out.push_back(std::move(r));
  }
  std::sort(out.begin(), out.end(), Better);
  return out;
}

std::optional<RelationResult> RelationSearch::BestTo(RelationKind kind, int subject,
                                                     const Mask& anchors,
                                                     const Mask* anchors2) const {
  const ObjectGeom& s = index_.geom(subject);
  std::optional<RelationResult> best;
  auto consider = [&](RelationResult r) {
    if (r.holds && (!best || Better(r, *best))) best = std::move(r);
  };
  if (kind == RelationKind::kBetween) {
    if (anchors2 == nullptr) return best;
    // Anchors of "between" lie on both sides within a few metres of the subject.
    std::vector<int> a1, a2;
    for (int i : index_.Candidates(s.box, eval_.options().directional_max_m)) {
      if (i == subject || !index_.eligible(i)) continue;
      if (anchors[i]) a1.push_back(i);
      if ((*anchors2)[i]) a2.push_back(i);
    }
    for (int a : a1) {
      for (int b : a2) {
        consider(eval_.Between(s, index_.geom(a), index_.geom(b), false));
      }
    }
    return best;
  }
  // The relation's reach around the subject bounds the anchors worth testing.
  for (int a : index_.Candidates(s.box, std::max(eval_.SearchRadius(kind, s), 0.01))) {
    if (a == subject || !anchors[a] || !index_.eligible(a)) continue;
    consider(Evaluate(kind, subject, a, false));
  }
  return best;
}

std::optional<RelationResult> RelationSearch::Support(int subject) const {
  const ObjectGeom& s = index_.geom(subject);
  const std::vector<int> near = index_.Candidates(s.box, 0.01);
  for (RelationKind kind : {RelationKind::kOn, RelationKind::kInside, RelationKind::kUnder}) {
    std::optional<RelationResult> best;
    int best_anchor = -1;
    for (int a : near) {
      if (a == subject || !index_.eligible(a)) continue;
      RelationResult r = eval_.Evaluate(kind, s, index_.geom(a), viewpoint_, false);
      if (r.holds && (!best || Better(r, *best))) {
        best = r;
        best_anchor = a;
      }
    }
    if (best) return eval_.Evaluate(kind, s, index_.geom(best_anchor), viewpoint_, true);
  }
  return std::nullopt;
}

std::optional<RelationSearch::Nearest> RelationSearch::NearestTo(
    const ObjectGeom& anchor, int anchor_index, const std::vector<char>& member) const {
  double radius = 1.0;
  while (true) {
    const std::vector<int> cands = index_.Candidates(anchor.box, radius);
    std::optional<Nearest> best;
    for (int i : cands) {
      if (!member[i] || i == anchor_index) continue;
      const double gap = BoxGap(index_.geom(i).box, anchor.box);
      if (!best || gap < best->gap_m) best = Nearest{i, anchor_index, gap};
    }
    // Objects outside the candidates are more than `radius` away horizontally; past this reach
    // every object is a candidate.
    const BoxG& b = index_.bounds();
    const double reach = HorizontalGap(anchor.box, b) + (b.max - b.min).head<2>().norm();
    if ((best && best->gap_m <= radius) || radius > reach) return best;
    radius *= 2.0;
  }
}

std::optional<RelationSearch::Nearest> RelationSearch::NearestPair(
    const std::vector<int>& subjects, const std::vector<int>* anchors) const {
  if (subjects.empty()) return std::nullopt;
  if (anchors == nullptr) {
    if (viewpoint_ == nullptr) return std::nullopt;
    ObjectGeom viewer;
    viewer.box.min = viewer.box.max = viewer.centroid_g = viewpoint_->position_g;
    std::vector<char> member(index_.size(), 0);
    for (int i : subjects) member[i] = 1;
    return NearestTo(viewer, -1, member);
  }
  std::optional<Nearest> best;
  if (subjects.size() * anchors->size() <= kBrutePairs) {
    for (int a : *anchors) {
      for (int s : subjects) {
        if (s == a) continue;
        const double gap = BoxGap(index_.geom(s).box, index_.geom(a).box);
        if (!best || gap < best->gap_m) best = Nearest{s, a, gap};
      }
    }
    return best;
  }
  std::vector<char> member(index_.size(), 0);
  for (int i : subjects) member[i] = 1;
  for (int a : *anchors) {
    auto n = NearestTo(index_.geom(a), a, member);
    if (n && (!best || n->gap_m < best->gap_m)) best = n;
  }
  return best;
}

}  // namespace loci::query
