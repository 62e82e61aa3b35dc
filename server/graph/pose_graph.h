// loci::server::PoseGraph: the keyframe pose graph (server/graph/README.md).
//
//   PoseGraph graph(options);                       // options.Validate() first
//   graph.AddKeyframe({id, robot, t_ns, T_map_kf, gravity_aligned, up_kf});  // up_kf: 0 = none
//   graph.AddOdometryEdge(prev_id, id, T_prev_kf, {quality, inliers});
//   graph.AddLoopEdge(a_id, b_id, T_a_b, information);      // verified, same robot
//   graph.AddMergeEdge(a_id, b_id, T_a_b, information);     // verified, two robots
//   auto result = graph.Optimize();  // result->updates: {keyframe_id, T_map_kf} that moved
//
// Optimize: odometry chains -> pairwise consistency of loop and merge edges (pcm.h) ->
// islands joined by the kept edges, a chain its join puts far away moved there rigidly ->
// Ceres (graph_problem.h) with the first keyframe of the reference robot (and of every other
// island) held constant -> kept edges with a residual above pcm.residual_chi2 dropped and the
// graph solved again from that solution -> the graph's estimates become the solution.
// Not thread-safe.
#pragma once

#include <unordered_map>
#include <vector>

#include "common/status.h"
#include "server/graph/graph_chains.h"
#include "server/graph/graph_options.h"
#include "server/graph/graph_problem.h"
#include "server/graph/graph_types.h"
#include "server/graph/pcm_cache.h"

namespace loci::server {

class PoseGraph {
 public:
  explicit PoseGraph(GraphOptions options);

  // InvalidArgument for a known id or a non-finite pose.
  Status AddKeyframe(const KeyframeNode& node);
  // Consecutive keyframes of one robot: a added before b, a without a successor, b without a
  // predecessor (a new odometry segment is simply a keyframe without this edge). Information
  // from `quality` (OdometryInformation).
  Status AddOdometryEdge(int64_t a_id, int64_t b_id, const SE3d& T_a_b,
                         const TrackingQuality& quality);
  // A verified loop within one robot / a merge between two robots; checked by the guard.
  Status AddLoopEdge(int64_t a_id, int64_t b_id, const SE3d& T_a_b, const Information6& info);
  Status AddMergeEdge(int64_t a_id, int64_t b_id, const SE3d& T_a_b, const Information6& info);
  // An object's centroid seen from a keyframe (used when options.landmarks.enabled).
  Status AddCentroidObservation(const CentroidObservation& observation);

  // Pairwise guard results to reuse and extend (pcm_cache.h), for a caller that solves a
  // growing graph again and again; it must outlive Optimize. nullptr: every pair is tested.
  void SetPcmCache(PcmCache* cache) { pcm_cache_ = cache; }

  StatusOr<GraphResult> Optimize();

  size_t size() const { return nodes_.size(); }
  const std::vector<KeyframeNode>& nodes() const { return nodes_; }  // current estimates
  const std::vector<GraphEdge>& edges() const { return edges_; }
  const GraphOptions& options() const { return options_; }

 private:
  StatusOr<size_t> Index(int64_t keyframe_id) const;
  Status AddConstraint(EdgeKind kind, int64_t a_id, int64_t b_id, const SE3d& T_a_b,
                       const Information6& info);
  OdometryChains Chains() const;
  // Per loop/merge edge (in edges_ order), whether the guard keeps it.
  std::vector<bool> GuardConstraints(const OdometryChains& chains) const;
  int ReferenceChain(const OdometryChains& chains) const;
  bool FourDof() const;
  // Edges (odometry + kept constraints), anchors and landmarks; newly joined chains placed.
  SolverInput BuildSolverInput(const OdometryChains& chains, const std::vector<bool>& keep,
                               bool four_dof, const std::vector<SE3d>& start,
                               size_t* islands) const;
  // The odometry's own T_a_b between keyframes of one local map (odometry.local_map_keyframes).
  void AddLocalMapEdges(const OdometryChains& chains, SolverInput* in) const;
  // Drops kept loop/merge edges whose squared whitened residual at the solution exceeds
  // pcm.residual_chi2; returns how many.
  size_t RejectByResidual(const std::vector<SE3d>& T_map_kf, std::vector<bool>* keep) const;
  // Takes the solution as the new estimates and lists the keyframes that moved.
  void ApplySolution(const SolverOutput& out, GraphResult* result);

  GraphOptions options_;
  std::vector<KeyframeNode> nodes_;
  std::unordered_map<int64_t, size_t> index_;
  std::vector<GraphEdge> edges_;
  std::vector<bool> has_next_, has_prev_;
  std::vector<TrackingQuality> quality_;  // per node: of its incoming odometry edge
  std::vector<CentroidObservation> observations_;
  PcmCache* pcm_cache_ = nullptr;
};

}  // namespace loci::server
