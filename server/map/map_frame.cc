#include "server/map/map_frame.h"

#include <cmath>

namespace loci::server {

UpEstimate EstimateUp(const FrameEvidence& e, const MapFrameOptions& options) {
  UpEstimate out;
  // A camera held level sees "up" along its -y axis (cam: x right, y down, z forward).
  const Vec3d level_up = e.T_base_first_cam.linear() * Vec3d(0, -1, 0);
  const bool has_gravity = e.gravity_count > 0 && e.gravity_sum_base.norm() > 1e-9;
  const Vec3d prior = has_gravity ? Vec3d(-e.gravity_sum_base.normalized()) : level_up;
  const std::optional<Vec3d> planes = EstimateUpFromPlanes(e.points_base, prior, options.planes);
  if (has_gravity) {
    const double cos_max = std::cos(options.plane_refine_max_deg * M_PI / 180.0);
    const bool refine = planes && planes->dot(prior) >= cos_max;
    out.up_base = refine ? *planes : prior;
    out.source = refine ? "gravity+planes" : "gravity";
  } else if (planes) {
    out.up_base = *planes;
    out.source = "planes";
  } else {
    out.up_base = level_up;
  }
  return out;
}

SE3d MapFromBase(const SE3d& T_base_first_cam, const Vec3d& up_base) {
  const Vec3d z = up_base.normalized();
  // Heading: the camera's optical axis on the floor; a camera looking straight down or up
  // falls back to its x axis turned by -90 deg about up (its "forward" on the floor).
  Vec3d forward = T_base_first_cam.linear() * Vec3d::UnitZ();
  forward -= forward.dot(z) * z;
  if (forward.norm() < 1e-3) {
    forward = z.cross(T_base_first_cam.linear() * Vec3d::UnitX());
  }
  const Vec3d x = forward.normalized();
  const Vec3d y = z.cross(x);
  Mat3d R_base_map;
  R_base_map << x, y, z;
  SE3d T_base_map = SE3d::Identity();
  T_base_map.linear() = R_base_map;
  T_base_map.translation() = T_base_first_cam.translation();
  return T_base_map.inverse();
}

}  // namespace loci::server
