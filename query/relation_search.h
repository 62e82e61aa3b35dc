// Relation queries over an indexed snapshot: which objects stand in a relation to an anchor,
// what supports an object, which object is nearest. Internal to the engine; uses the index's
// grid so a query touches only the objects around its anchor.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "query/map_index.h"
#include "query/relations.h"

namespace loci::query {

class RelationSearch {
 public:
  // `viewpoint`: the viewer for left / right / front / behind (may be null).
  RelationSearch(const MapIndex& index, const RelationEvaluator& evaluator,
                 const ViewpointG* viewpoint)
      : index_(index), eval_(evaluator), viewpoint_(viewpoint) {}

  // Relation of object `subject` to object `anchor` (indices). Query semantics: "above" also
  // accepts "on", "under" and "below" accept each other.
  RelationResult Evaluate(RelationKind kind, int subject, int anchor, bool evidence) const;

  // Membership masks over the index (mask[i] != 0: object i belongs). Null = every object.
  using Mask = std::vector<char>;
  Mask MakeMask(const std::vector<int>& indices) const;

  // Eligible objects in `subjects` holding `kind` to `anchor`, best confidence first. Evidence
  // is left empty (it costs a string per result): add it with WithEvidence for what is shown.
  std::vector<RelationResult> SubjectsOf(RelationKind kind, int anchor, const Mask* subjects) const;
  // Eligible objects in `subjects` between anchors a and b (no evidence).
  std::vector<RelationResult> SubjectsBetween(int a, int b, const Mask* subjects) const;
  // Best holding relation of `subject` to any object of `anchors` (no evidence), nullopt when
  // none holds. For kBetween `anchors2` gives the second anchor set.
  std::optional<RelationResult> BestTo(RelationKind kind, int subject, const Mask& anchors,
                                       const Mask* anchors2) const;
  // Re-evaluates `r` with its evidence sentence.
  void WithEvidence(RelationResult* r) const;
  // What holds `subject` up or contains it: the best "on", else "inside", else "under".
  std::optional<RelationResult> Support(int subject) const;
  // Nearest (smallest box gap) pair subject-in-`subjects` x anchor-in-`anchors`, or to the
  // viewer when `anchors` is null. Returns {subject, anchor (-1 = viewer), gap_m}.
  struct Nearest {
    int subject = -1;
    int anchor = -1;
    double gap_m = 0;
  };
  std::optional<Nearest> NearestPair(const std::vector<int>& subjects,
                                     const std::vector<int>* anchors) const;

  const ViewpointG* viewpoint() const { return viewpoint_; }

 private:
  // Nearest member (member[i] != 0) to `anchor`, growing the grid search radius.
  std::optional<Nearest> NearestTo(const ObjectGeom& anchor, int anchor_index,
                                   const std::vector<char>& member) const;

  const MapIndex& index_;
  const RelationEvaluator& eval_;
  const ViewpointG* viewpoint_;
};

}  // namespace loci::query
