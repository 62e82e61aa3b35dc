#include "common/map_object.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace loci {

MapObject Transformed(MapObject o, const SE3d& T_b_a) {
  const Eigen::Vector3d lo = o.aabb_min_m, hi = o.aabb_max_m;
  o.aabb_min_m.setConstant(1e300);
  o.aabb_max_m.setConstant(-1e300);
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3d c(corner & 1 ? hi.x() : lo.x(), corner & 2 ? hi.y() : lo.y(),
                            corner & 4 ? hi.z() : lo.z());
    const Eigen::Vector3d m = T_b_a * c;
    o.aabb_min_m = o.aabb_min_m.cwiseMin(m);
    o.aabb_max_m = o.aabb_max_m.cwiseMax(m);
  }
  o.centroid_m = T_b_a * o.centroid_m;
  o.obb_center_m = T_b_a * o.obb_center_m;
  o.R_map_box = T_b_a.linear() * o.R_map_box;
  for (ObjectPlaceChange& c : o.history) {
    c.centroid_m = T_b_a * c.centroid_m;
    c.from_m = T_b_a * c.from_m;
  }
  const bool keeps_up = T_b_a.linear()(2, 2) > 1.0 - 1e-9;
  for (double* z_m : {&o.top_surface_z_m, &o.bottom_z_m}) {
    *z_m = keeps_up ? *z_m + T_b_a.translation().z() : std::numeric_limits<double>::quiet_NaN();
  }
  return o;
}

double BottomZ(const MapObject& o) {
  const double box_bottom_m = std::min(o.aabb_min_m.z(), o.aabb_max_m.z());
  const double box_top_m = std::max(o.aabb_min_m.z(), o.aabb_max_m.z());
  const bool known = std::isfinite(o.bottom_z_m) && o.bottom_z_m >= box_bottom_m &&
                     o.bottom_z_m <= box_top_m;
  return known ? o.bottom_z_m : box_bottom_m;
}

}  // namespace loci
