// Pairwise consistency results kept from one solve to the next. The server builds a new
// PoseGraph for every solve over a graph that mostly only grew (server/align/loop_closer.h);
// testing every pair of loop edges again each time cost O(n^2) per solve (2.2 s at 3700 loops)
// and an n x n matrix of memory. A pair's test depends only on the two edges and on the
// odometry between their ends, which keyframes appended to a chain do not change, so each
// solve tests only its new edges against the rest of their group, and only the inconsistent
// pairs (few) are kept. The results are exactly those of testing every pair again.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <set>
#include <utility>
#include <vector>

#include "server/graph/graph_chains.h"

namespace loci::server {

// One loop or merge edge of a group as the cache knows it: its graph edge (keyframe ids, as
// added) and its oriented measurement (a changed measurement is a new edge).
struct PcmCachedEdge {
  std::pair<int64_t, int64_t> ids;
  SE3d T_a_b = SE3d::Identity();
  Covariance6 cov = Covariance6::Identity();
};

class PcmCache {
 public:
  // Starts a solve. Forgets every result when the chi2 threshold changed or a chain seen before
  // is not what it was plus keyframes appended at its end (its odometry poses would differ).
  // node_ids: keyframe id per node index.
  void BeginSolve(const OdometryChains& chains, const std::vector<int64_t>& node_ids,
                  double chi2_threshold);
  // The conflict lists (max_clique.h) of a group's edges, in the given order. Pairs not known
  // are tested with consistent(i, j), i < j (indices into `edges`); edges of the group not in
  // `edges` are forgotten. group: the keyframe ids that start the group's two chains.
  std::vector<std::vector<int>> GroupConflicts(
      std::pair<int64_t, int64_t> group, const std::vector<PcmCachedEdge>& edges,
      const std::function<bool(size_t, size_t)>& consistent);
  // Ends a solve: groups the solve did not touch are forgotten.
  void EndSolve();
  // The group key of chains ca, cb of the solve begun (their first keyframes' ids).
  std::pair<int64_t, int64_t> GroupKey(const OdometryChains& chains, int ca, int cb) const {
    return {node_ids_[chains.members[ca].front()], node_ids_[chains.members[cb].front()]};
  }

  size_t pairs_tested() const { return pairs_tested_; }  // over the cache's life

 private:
  struct Entry {
    uint64_t measurement = 0;  // MeasurementHash of T_a_b and cov
    std::vector<std::pair<int64_t, int64_t>> conflicts;
  };
  // A hash of the measurement's bytes (a changed measurement is a new edge).
  static uint64_t MeasurementHash(const PcmCachedEdge& edge);
  using Group = std::map<std::pair<int64_t, int64_t>, Entry>;
  static void Forget(Group* group, Group::iterator it);

  double chi2_threshold_ = -1;
  std::vector<int64_t> node_ids_;                   // of the solve begun
  std::map<int64_t, std::vector<int64_t>> chains_;  // first keyframe id -> ids in chain order
  std::map<std::pair<int64_t, int64_t>, Group> groups_;
  // The groups the solve begun used: EndSolve keeps these and forgets the others.
  std::set<std::pair<int64_t, int64_t>> touched_;
  size_t pairs_tested_ = 0;
};

}  // namespace loci::server
