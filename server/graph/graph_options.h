// Options of the keyframe pose graph (server/graph/README.md): odometry information from the
// client's tracking quality, the wrong-loop guard (pairwise consistency), robust losses, the
// 4-DoF mode, the solver, and the optional object-centroid landmarks. Every field documents its
// unit and default; FromYaml reads only the keys present of the `graph:` section of
// config/server.yaml and checks for unknown keys.
#pragma once

#include <yaml-cpp/yaml.h>

#include <string>

#include "common/status.h"

namespace loci::server {

// Information (inverse covariance) of an odometry edge T_a_b between consecutive keyframes.
// Standard deviations at full tracking quality:
//   sigma_t = sigma_trans_m + sigma_trans_per_m * |t_a_b|        (each axis, m)
//   sigma_r = sigma_rot_rad + sigma_rot_per_rad * angle(T_a_b)  (each axis, rad)
// Tracking quality q in [0, 1] (the client's, or min(1, inliers / full_quality_inliers) when
// only the PnP inlier count is known, or 1 when neither is) scales both:
//   sigma / max(q, min_quality), so information = information(q = 1) * max(q, min_quality)^2.
// Quality 0.5 doubles the standard deviations; a lost-then-relocalised edge (q = 0) counts
// 1 / min_quality^2 = 100 times less than a good one.
struct OdometryInformationOptions {
  double sigma_trans_m = 0.005;      // translation noise floor per edge, m (0.005)
  double sigma_trans_per_m = 0.02;   // plus this fraction of the edge's length (0.02)
  double sigma_rot_rad = 0.002;      // rotation noise floor per edge, rad (0.002, 0.11 deg)
  double sigma_rot_per_rad = 0.02;   // plus this fraction of the edge's rotation angle (0.02)
  int full_quality_inliers = 100;    // inlier count that counts as quality 1 (100)
  double min_quality = 0.1;          // quality floor, so no edge loses all weight (0.1)
  // A client that tracks against a local map of its last N keyframes (loci-track: its
  // tracker.local_map_keyframes window) measured each keyframe's pose against points that the
  // window's older keyframes observe too: its odometry between two keyframes of one window does
  // not drift as a chain of independent steps. With N > 2, keyframes of a chain also get edges
  // within N keyframes, as ORB-SLAM's covisibility edges: every keyframe from the last anchor
  // (every 8th keyframe) before it, every anchor from the anchors 8, 16, ... (< N) before it;
  // each the odometry's T_a_b with the information of one edge of that motion (the model above,
  // b's quality), and only where the client reported the quality of every step between (a pose
  // of unknown quality, such as a file's, was tracked against no local map). 0 (default):
  // consecutive edges only.
  int local_map_keyframes = 0;
};

// Pairwise consistency maximisation (PCM, Mangelson et al. 2018) over loop and merge edges:
// two edges joining the same pair of odometry chains are consistent when the cycle
// edge_i * odometry(b_i -> b_j) * edge_j^-1 * odometry(a_j -> a_i) is the identity within its
// propagated covariance (squared Mahalanobis distance <= chi2_threshold). The largest set of
// pairwise consistent edges of each chain pair is kept (greedy clique, max_clique.h); a set
// smaller than min_set_size is rejected whole.
// A second check after the solve: a kept edge whose squared whitened residual at the solution
// exceeds residual_chi2 is dropped and the graph solved again from that solution (once).
// Pairwise tests between edges far apart along the odometry are weak (the segments' covariance
// is large); at the solution, held by all the other edges, a wrong edge stands out.
struct PcmOptions {
  bool enabled = true;
  double chi2_threshold = 16.81;  // 6 DoF, 99 % (16.81)
  int min_set_size = 2;           // a lone loop waits for a second consistent one (2)
  double residual_chi2 = 100;     // the check after the solve; 0 = off (100)
};

// Robust loss on loop and merge edges (odometry edges have none). Residuals are whitened by the
// edge information, so the scale is in standard deviations.
struct RobustLossOptions {
  std::string type = "huber";  // "huber", "cauchy" or "none" (huber)
  double scale = 3.0;          // Huber/Cauchy parameter a, in standard deviations (3.0)
};

// Object-centroid constraints (paper 000 section 3.4, eqs. 19-20): each fused object's centroid
// is a 3-D landmark, and each keyframe that observed it adds the residual
// (R_map_kf^T (c_map - t_map_kf) - c_kf) / sigma_m under the loss below.
struct LandmarkOptions {
  bool enabled = false;      // off by default: no gain measured on a real sequence (false)
  double sigma_m = 0.05;     // standard deviation of an observed centroid, each axis, m (0.05)
  double huber_m = 0.10;     // Huber threshold on the centroid error, m (0.10)
  int min_observations = 2;  // landmarks seen by fewer keyframes are left out (2)
  // Only objects up to this long are landmarks on the server (MapServer): one view of a larger
  // one (a desk, a chair) shows a part of it, centred elsewhere than the next view's, m (0.6)
  double max_object_size_m = 0.6;
};

// Per-keyframe gravity priors: a keyframe that carries its own gravity measurement (the client's
// accelerometer) gets the residual ((R_map_kf * up_kf).x, .y) / sigma_rad under a Cauchy loss
// of loss_scale sigmas: its tilt is pulled towards the measured up. With them, dof "auto"
// solves in 6-DoF instead of 4-DoF: a visual odometry's roll and pitch drift (4.9 deg of tilt
// between frames 0 and 300 of a real TUM sequence), which the 4-DoF mode holds as if it were
// gravity, can then follow the loops and merges, pulled to gravity; loops that agree on a wrong
// tilt still tilt the map in part (server/graph/README.md), so off by default. sigma_rad 0 = off.
struct GravityPriorOptions {
  double sigma_rad = 0.0;
  double loss_scale = 2.0;
};

struct GraphSolverOptions {
  int max_iterations = 100;        // Levenberg-Marquardt iterations (100)
  int threads = 1;                 // Ceres threads; the server shares its cores (1)
  double function_tolerance = 1e-6;  // relative cost change that stops the solver (1e-6)
};

struct GraphOptions {
  OdometryInformationOptions odometry;
  PcmOptions pcm;
  RobustLossOptions loss;
  LandmarkOptions landmarks;
  GravityPriorOptions gravity;
  GraphSolverOptions solver;
  // "auto": 4-DoF (x, y, z, yaw per keyframe; roll and pitch held) when every keyframe's
  // orientation is gravity-aligned (the map frame is z up) and gravity priors are off or some
  // keyframe has no gravity measurement, else 6-DoF (with the priors); "4dof": required,
  // FailedPrecondition otherwise; "6dof": always full 6-DoF (auto).
  std::string dof = "auto";
  // The robot whose first keyframe is held constant (the gauge); other islands hold their own
  // first keyframe. Empty = the robot of the first keyframe added ("").
  std::string reference_robot;
  // A chain (robot or odometry segment) that a kept loop or merge edge places more than
  // place_trans_m or place_rot_rad away from its estimate (a robot that started unaligned) is
  // first moved there rigidly, so the solver starts near the answer, m and rad (0.5, 0.17).
  double place_trans_m = 0.5;
  double place_rot_rad = 0.17;
  // A keyframe whose pose changed by more than this is reported as moved, m and rad (0.002, 0.001).
  double moved_trans_m = 0.002;
  double moved_rot_rad = 0.001;

  Status FromYaml(const YAML::Node& node);
  Status Validate() const;
};

}  // namespace loci::server
