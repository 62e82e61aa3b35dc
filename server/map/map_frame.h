// The map frame (ROS REP-103/105: x forward, y left, z up, metres). Keyframe poses reach the
// mapper in the base frame (the first robot's odometry frame; other robots are placed in it by
// their session's T_base_odom). The map frame is the base frame levelled and re-anchored:
//   - origin: the first keyframe's camera centre;
//   - z: up, from the gravity the clients send (the mean over the first keyframes), refined by
//     the dominant horizontal planes (floor, table tops) when they agree within
//     plane_refine_max_deg; without gravity, from those planes alone, with the first camera held
//     level (its -y axis) as the prior;
//   - x: the first camera's optical axis projected on the floor.
// The mapper fixes the frame from the first keyframe at once and re-derives the map once from
// the first `settle_keyframes` keyframes' products with the better estimate.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "common/se3.h"
#include "server/map/up_estimate.h"

namespace loci::server {

struct MapFrameOptions {
  // Keyframes whose gravity and planes fix the map frame; the map is re-derived once when the
  // last of them is in. 1 = the first keyframe alone (never re-derived) (10).
  int settle_keyframes = 10;
  // Planes replace the clients' mean gravity when within this angle of it, deg (5).
  double plane_refine_max_deg = 5.0;
  PlaneUpOptions planes;
};

// What the frame estimate saw: gravity (unit, pointing down) and static points, both in the
// base frame.
struct FrameEvidence {
  SE3d T_base_first_cam = SE3d::Identity();
  Vec3d gravity_sum_base = Vec3d::Zero();
  int gravity_count = 0;
  std::vector<Eigen::Vector3f> points_base;
};

// Up in the base frame, and where it came from: "gravity+planes", "gravity", "planes" or
// "level-camera".
struct UpEstimate {
  Vec3d up_base = Vec3d::UnitZ();
  const char* source = "level-camera";
};
UpEstimate EstimateUp(const FrameEvidence& evidence, const MapFrameOptions& options);

// T_map_base for an up direction (base frame) and the first keyframe's camera pose.
SE3d MapFromBase(const SE3d& T_base_first_cam, const Vec3d& up_base);

}  // namespace loci::server
