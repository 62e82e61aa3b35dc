// Boxes that stand upright in the z-up map frame: one axis is the map's up, the other two follow
// the object's edges on the floor. A desk, a book or a keyboard lies square to the floor, so
// its box turns only about up; the principal axes of a partial cloud (a desk's strip in front
// of the monitors) lean and turn with whatever part the camera saw.
#pragma once

#include <Eigen/Core>
#include <vector>

namespace loci::server {

struct UprightBox {
  // Columns: the longer horizontal side, the shorter one, the map's up (z).
  Eigen::Matrix3d R_map_box = Eigen::Matrix3d::Identity();
  Eigen::Vector3d center_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d half_extent_m = Eigen::Vector3d::Zero();
};

// The upright box of the points (map frame): its yaw is the one of the smallest-area rectangle
// that holds their footprint (cv::minAreaRect), its height their height range. `pts_m` must not
// be empty; a single point or a line gives zero half extents across.
UprightBox FitUprightBox(const std::vector<Eigen::Vector3d>& pts_m);

// Centre of the points' box along the axes of R_map_box (columns; map frame). `pts_m` must not
// be empty.
Eigen::Vector3d BoxCentreAlong(const std::vector<Eigen::Vector3d>& pts_m,
                               const Eigen::Matrix3d& R_map_box);

}  // namespace loci::server
