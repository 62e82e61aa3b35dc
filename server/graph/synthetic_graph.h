// Synthetic pose graphs with exact ground truth, for the tests and `loci bench graph`: a camera
// driving laps of a square with noisy, biased odometry, loop and merge edges from the true
// poses plus noise, object centroids seen along the way. Nothing here is measured data.
#pragma once

#include <random>
#include <string>
#include <vector>

#include "common/status.h"
#include "common/tum_io.h"
#include "server/graph/graph_types.h"

namespace loci::server {

class PoseGraph;

struct SquarePathOptions {
  int keyframes = 200;
  int keyframes_per_lap = 100;
  double side_m = 4.0;
  double lap_phase = 0;           // start this fraction of a lap along the perimeter
  double z_amplitude_m = 0.2;     // height wobble (one period per side), m
  double camera_pitch_rad = 0.17; // the camera looks this far down
  SE3d T_map_square = SE3d::Identity();  // placement of the square (centre, z up)
};
// True T_map_kf along the square: counter-clockwise laps, camera facing the direction of travel.
std::vector<SE3d> SquarePath(const SquarePathOptions& options);

struct OdometryNoiseOptions {
  double trans_sigma_m = 0.003;  // per edge, each axis
  double rot_sigma_rad = 0.002;  // per edge, each axis
  double yaw_bias_rad = 0.002;   // per edge, about the map's up axis (drift)
  double scale_bias = 0.01;      // odometry translations are (1 + this) times too long
};

struct SyntheticRobot {
  std::string robot;
  std::vector<KeyframeNode> nodes;  // initial estimates: the noisy odometry composed
  std::vector<SE3d> T_map_kf_true;
  std::vector<SE3d> T_prev_kf;      // odometry measurement from keyframe k-1 to k (k >= 1)
};

// Keyframe ids first_id.., t_ns = id * 0.1 s. The estimate starts at T_map_first_guess (the
// truth's first pose for an aligned robot, anything for one that starts unaligned). With
// gravity_aligned, each estimate's roll and pitch are replaced by the true ones (as an
// accelerometer would give) and the nodes are flagged gravity-aligned.
SyntheticRobot MakeSyntheticRobot(const std::string& robot, int64_t first_id,
                                  const std::vector<SE3d>& truth,
                                  const OdometryNoiseOptions& noise,
                                  const SE3d& T_map_first_guess, bool gravity_aligned,
                                  std::mt19937* rng);

struct ProximityEdgeOptions {
  double max_distance_m = 0.3;   // true distance of the two keyframes
  double max_angle_rad = 0.5;    // true rotation between them
  int every = 5;                 // one edge per this many keyframes of robot b, at most
  int min_gap = 30;              // same robot: a at least this many keyframes before b
  double trans_sigma_m = 0.01;   // noise added to the measurement and its information
  double rot_sigma_rad = 0.005;
};
// Edges a -> b measuring the true T_a_b plus noise, to the closest qualifying keyframe of a.
std::vector<GraphEdge> ProximityEdges(const SyntheticRobot& a, const SyntheticRobot& b,
                                      EdgeKind kind, const ProximityEdgeOptions& options,
                                      std::mt19937* rng);

// Object centroids scattered around the square, and their noisy observations: an object is
// seen from a keyframe when in front of it, within max_range_m and a 70 x 55 deg field of view.
std::vector<Vec3d> ObjectsAroundSquare(const SquarePathOptions& path, int count,
                                       std::mt19937* rng);
std::vector<CentroidObservation> ObserveCentroids(const SyntheticRobot& robot,
                                                  const std::vector<Vec3d>& objects_map,
                                                  double max_range_m, double sigma_m,
                                                  std::mt19937* rng);

// Adds the robot's nodes and odometry edges (quality 1), or the edges (loop/merge by kind).
Status AddRobot(const SyntheticRobot& robot, PoseGraph* graph);
Status AddConstraints(const std::vector<GraphEdge>& edges, PoseGraph* graph);

// For ComputeAte: the truth, and the graph's current estimate of the robot's keyframes.
Trajectory TrueTrajectory(const SyntheticRobot& robot);
Trajectory EstimatedTrajectory(const SyntheticRobot& robot, const PoseGraph& graph);

}  // namespace loci::server
