#include "tests/server/mapper_views.h"

#include <algorithm>
#include <cmath>

namespace loci::server::testing {

std::vector<MapperKeyframe> Views(const std::vector<WorldBox>& boxes, int n, bool masks,
                                  const Eigen::Vector3d& target, int64_t first_id) {
  const PinholeCamera cam = PinholeCamera::TumFr1();
  std::vector<MapperKeyframe> out;
  for (int i = 0; i < n; ++i) {
    const double az = (-125.0 + 70.0 * i / std::max(1, n - 1)) * M_PI / 180.0;
    const Eigen::Vector3d eye =
        target + Eigen::Vector3d(1.4 * std::cos(az), 1.4 * std::sin(az), 0.9);
    MapperKeyframe kf;
    kf.keyframe_id = first_id + i;
    kf.session_row = 1;
    kf.robot = "robot1";
    kf.t_ns = 1'000'000'000LL * kf.keyframe_id;
    kf.T_base_kf = LookAt(eye, target);  // base = the boxes' world frame, z up
    kf.camera = cam;
    RenderedView v = Render(boxes, cam, kf.T_base_kf, masks);
    kf.bgr = v.bgr;
    kf.depth_m = v.depth_m;
    kf.detections = v.detections;
    kf.has_gravity = true;
    kf.gravity_cam = kf.T_base_kf.rotation().transpose() * Eigen::Vector3d(0, 0, -1);
    out.push_back(std::move(kf));
  }
  return out;
}

MapOptions BoxWorldOptions() {
  MapOptions o;
  o.mapped_classes = {"book", "cup", "laptop", "person"};
  o.dynamic_classes = {"person"};
  return o;
}

}  // namespace loci::server::testing
