// Types of the keyframe pose graph: nodes, edges, what an optimisation returns.
// Frames: `map` is the shared map frame (z up when gravity is known), `kf` a keyframe's camera
// frame; an edge from keyframe a to keyframe b measures T_a_b (p_a = T_a_b * p_b).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "common/se3.h"

namespace loci::server {

// 6x6 information (inverse covariance) of a relative pose, in the order of the residual:
// translation (x, y, z of frame a, m), then rotation (angle-axis vector of frame a, rad).
using Information6 = Eigen::Matrix<double, 6, 6>;
using Covariance6 = Eigen::Matrix<double, 6, 6>;

// Diagonal information from one translation and one rotation standard deviation.
Information6 IsotropicInformation(double sigma_trans_m, double sigma_rot_rad);

struct KeyframeNode {
  int64_t keyframe_id = 0;
  std::string robot;      // robot (session) name; odometry edges join keyframes of one robot
  int64_t t_ns = 0;
  SE3d T_map_kf = SE3d::Identity();  // initial estimate
  // Roll and pitch of T_map_kf come from gravity (the map frame is z up). All nodes aligned
  // allows the 4-DoF mode (GraphOptions::dof).
  bool gravity_aligned = false;
  // The keyframe's own measured up direction in its frame (unit; minus the accelerometer's
  // gravity), for GravityPriorOptions; zero = none.
  Vec3d up_kf = Vec3d::Zero();
};

// The client's tracking quality of an odometry edge; negative = unknown.
struct TrackingQuality {
  double quality = -1;  // in [0, 1]
  int inliers = -1;     // PnP inliers of the later keyframe
};

enum class EdgeKind { kOdometry, kLoop, kMerge };
const char* EdgeKindName(EdgeKind kind);

struct GraphEdge {
  EdgeKind kind = EdgeKind::kOdometry;
  int64_t from_id = 0;  // keyframe a
  int64_t to_id = 0;    // keyframe b
  SE3d T_a_b = SE3d::Identity();
  Information6 information = Information6::Identity();
};

// A fused object's centroid seen from a keyframe (paper 000 eq. 19): c_kf in the kf frame, m.
struct CentroidObservation {
  int64_t keyframe_id = 0;
  int64_t object_id = 0;
  Vec3d c_kf_m = Vec3d::Zero();
};

// A corrected keyframe pose, for Mapper::UpdateKeyframePoses (which takes T_base_kf:
// T_base_kf = T_map_base^-1 * T_map_kf).
struct KeyframePoseUpdate {
  int64_t keyframe_id = 0;
  SE3d T_map_kf = SE3d::Identity();
};

struct EdgeRef {
  EdgeKind kind = EdgeKind::kLoop;
  int64_t from_id = 0;
  int64_t to_id = 0;
};

struct GraphStats {
  size_t nodes = 0;
  size_t odometry_edges = 0;
  size_t loop_edges = 0;   // given
  size_t merge_edges = 0;  // given
  size_t loops_accepted = 0, loops_rejected = 0;
  size_t merges_accepted = 0, merges_rejected = 0;
  size_t rejected_after_solve = 0;     // of the rejected: by their residual after the solve
  size_t landmarks = 0;                // used (seen by enough keyframes)
  size_t centroid_observations = 0;    // used
  size_t gravity_priors = 0;           // keyframes with a gravity prior
  size_t islands = 0;       // connected components after the accepted edges; one is anchored each
  size_t moved = 0;         // keyframes reported in the updates
  bool four_dof = false;    // the solve held roll and pitch
  double pcm_ms = 0;        // consistency check and clique, wall ms
  double solve_ms = 0;      // Ceres, wall ms
  double initial_cost = 0;  // Ceres cost (1/2 sum of squared whitened residuals, after losses)
  double final_cost = 0;
  int iterations = 0;
  bool converged = false;   // Ceres stopped on a tolerance (not on the iteration limit)
};

struct GraphResult {
  std::vector<KeyframePoseUpdate> updates;  // keyframes that moved, in keyframe id order
  std::vector<EdgeRef> rejected;            // loop and merge edges left out by the guard
  GraphStats stats;
};

}  // namespace loci::server
