#include "common/map_object.h"

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
  return o;
}

}  // namespace loci
