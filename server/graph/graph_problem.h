// The pose graph as a Ceres problem: keyframe poses (translation + unit quaternion, or
// translation + yaw in the 4-DoF mode), relative-pose edges, optional centroid landmarks.
#pragma once

#include <vector>

#include "common/status.h"
#include "server/graph/graph_options.h"
#include "server/graph/graph_types.h"

namespace loci::server {

struct SolverEdge {
  size_t a = 0, b = 0;  // node indices
  SE3d T_a_b = SE3d::Identity();
  Information6 information = Information6::Identity();
  bool robust = false;  // loop and merge edges get GraphOptions::loss
};

struct SolverObservation {
  size_t node = 0;
  size_t landmark = 0;  // index into the landmark list
  Vec3d c_kf_m = Vec3d::Zero();
};

struct SolverInput {
  std::vector<SE3d> T_map_kf;  // initial poses, per node
  std::vector<SolverEdge> edges;
  std::vector<size_t> anchors;  // nodes held constant (one per island)
  bool four_dof = false;
  std::vector<Vec3d> landmarks_map;  // initial centroids, map frame
  std::vector<SolverObservation> observations;
  std::vector<std::pair<size_t, Vec3d>> gravity;  // (node, up_kf): gravity priors
};

struct SolverOutput {
  std::vector<SE3d> T_map_kf;
  std::vector<Vec3d> landmarks_map;
  double initial_cost = 0, final_cost = 0;
  int iterations = 0;
  bool converged = false;
  double solve_ms = 0;
};

// Internal (Ceres failed to run) when the problem cannot be solved.
StatusOr<SolverOutput> SolvePoseGraph(const SolverInput& input, const GraphOptions& options);

}  // namespace loci::server
