// Spatial relations between map objects in the gravity frame (geometry.h), each with a
// confidence in [0, 1] and human-readable evidence. "subject REL anchor": the book (subject) is
// on the table (anchor).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "query/geometry.h"
#include "query/query_options.h"

namespace loci::query {

enum class RelationKind {
  kOn,
  kUnder,
  kAbove,
  kBelow,
  kNear,
  kNextTo,
  kInside,
  kBetween,
  kNearest,
  kLeftOf,
  kRightOf,
  kInFrontOf,
  kBehind,
};

// Wire name as in proto Relation.name: "on", "next_to", "left_of", "in_front_of" ...
std::string_view RelationName(RelationKind kind);
// English phrase for sentences: "on", "next to", "to the left of" ...
std::string_view RelationPhrase(RelationKind kind);
std::optional<RelationKind> RelationFromName(std::string_view name);
// Left / right / in front / behind are relative to a viewer.
bool NeedsViewpoint(RelationKind kind);

struct RelationResult {
  RelationKind kind = RelationKind::kNear;
  int64_t subject_id = 0;
  int64_t anchor_id = 0;
  int64_t anchor2_id = 0;  // second anchor of "between", else 0
  bool holds = false;      // confidence >= RelationOptions::min_confidence and hard limits met
  double confidence = 0;   // [0, 1]
  double distance_m = 0;   // gap between the two boxes (between: to the anchors' segment)
  std::string evidence;    // e.g. "bottom 0.01 m above the top surface, footprint overlap 0.85"
};

class RelationEvaluator {
 public:
  explicit RelationEvaluator(const RelationOptions& options) : opt_(options) {}

  // One pairwise relation. `viewpoint` is required by NeedsViewpoint kinds (holds = false and the
  // evidence says so without one). kBetween and kNearest are not pairwise: use Between() and the
  // engine's ranking. Evidence is formatted only when `with_evidence`.
  RelationResult Evaluate(RelationKind kind, const ObjectGeom& subject, const ObjectGeom& anchor,
                          const ViewpointG* viewpoint = nullptr, bool with_evidence = true) const;
  // Subject between anchors a and b (horizontally).
  RelationResult Between(const ObjectGeom& subject, const ObjectGeom& a, const ObjectGeom& b,
                         bool with_evidence = true) const;

  // Largest box gap at which `kind` can hold for these two objects (m): the search radius of the
  // spatial index. Vertical relations return the anchor-relative reach used for candidates.
  double SearchRadius(RelationKind kind, const ObjectGeom& anchor) const;

  const RelationOptions& options() const { return opt_; }

 private:
  RelationResult On(const ObjectGeom& s, const ObjectGeom& a, bool ev) const;
  RelationResult Under(const ObjectGeom& s, const ObjectGeom& a, bool ev) const;
  RelationResult Above(const ObjectGeom& s, const ObjectGeom& a, bool ev) const;
  RelationResult Below(const ObjectGeom& s, const ObjectGeom& a, bool ev) const;
  RelationResult Near(const ObjectGeom& s, const ObjectGeom& a, bool ev) const;
  RelationResult NextTo(const ObjectGeom& s, const ObjectGeom& a, bool ev) const;
  RelationResult Inside(const ObjectGeom& s, const ObjectGeom& a, bool ev) const;
  RelationResult Directional(RelationKind kind, const ObjectGeom& s, const ObjectGeom& a,
                             const ViewpointG* v, bool ev) const;
  double NearThreshold(const ObjectGeom& s, const ObjectGeom& a) const;

  RelationOptions opt_;
};

}  // namespace loci::query
