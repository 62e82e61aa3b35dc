// The up direction of a scene from its dominant horizontal planes (floors, table tops): planes
// are extracted with PCL RANSAC (fixed seed, so the same cloud gives the same answer), their
// normals flipped towards a prior up, those within max_tilt_deg of the prior grouped, and the
// group with the most inliers wins (inlier-weighted mean normal).
#pragma once

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "common/se3.h"

namespace loci::server {

struct PlaneUpOptions {
  double voxel_m = 0.08;             // the cloud is thinned to this voxel first, m (0.08)
  double plane_distance_m = 0.03;    // RANSAC inlier distance, m (0.03)
  int max_planes = 6;                // planes extracted at most (6)
  double min_plane_fraction = 0.05;  // a plane needs this share of the cloud's points (0.05)
  double max_tilt_deg = 45.0;        // normals within this angle of the prior are horizontal (45)
  double cluster_deg = 10.0;         // normals within this angle agree (10)
};

// Up (unit, the points' frame) or nullopt when no horizontal plane qualifies.
std::optional<Vec3d> EstimateUpFromPlanes(const std::vector<Eigen::Vector3f>& points,
                                          const Vec3d& prior_up, const PlaneUpOptions& options);

}  // namespace loci::server
