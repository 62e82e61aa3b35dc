// Hand-built realistic scenes for the query tests (map frame, z up, metres).
#pragma once

#include <string>
#include <vector>

#include "common/map_object.h"
#include "common/se3.h"

namespace loci::query::testing {

constexpr int64_t kT0 = 1'000'000'000'000;  // "now" of the tests (ns)

inline MapObject Box(int64_t id, const std::string& cls, const Vec3d& min_m, const Vec3d& max_m,
                     const std::vector<std::string>& robots = {"robot-a"},
                     int64_t last_ns = kT0 - 5'000'000'000) {
  MapObject o;
  o.id = id;
  o.class_name = cls;
  o.confidence = 0.9;
  o.labels = {{cls, 0.9}, {"other", 0.1}};
  o.aabb_min_m = min_m;
  o.aabb_max_m = max_m;
  o.centroid_m = 0.5 * (min_m + max_m);
  o.obb_center_m = o.centroid_m;
  o.obb_half_extent_m = 0.5 * (max_m - min_m);
  o.robots = robots;
  o.last_robot = robots.empty() ? "" : robots.back();
  o.first_seen_ns = last_ns;
  o.last_seen_ns = last_ns;
  o.confirmed = true;
  o.observation_count = 5;
  return o;
}

// An office: a dining table (#1) with a book, cup, keyboard and laptop on it, a chair tucked
// under it (#5) and one standing away (#6); a shelf (#7) with a book on top (#8); a desk (#10,
// class dining table) with a monitor (#9), a mouse right of it (#11), a plant left of it (#12)
// and a keyboard in front (#13), seen from the viewpoint of OfficeViewpoint().
inline std::vector<MapObject> Office() {
  return {
      Box(1, "dining table", {0, 0, 0}, {1.6, 0.9, 0.75}),
      Box(2, "book", {0.2, 0.2, 0.75}, {0.42, 0.36, 0.79}),
      Box(3, "cup", {1.0, 0.5, 0.75}, {1.08, 0.58, 0.85}),
      Box(4, "keyboard", {0.6, 0.1, 0.75}, {1.04, 0.24, 0.78}),
      Box(5, "chair", {0.3, 0.6, 0}, {0.75, 1.05, 0.9}),
      Box(6, "chair", {2.5, 0.2, 0}, {2.95, 0.65, 0.9}),
      Box(7, "shelf", {3, 0, 0}, {3.8, 0.3, 1.2}),
      Box(8, "book", {3.1, 0.05, 1.2}, {3.26, 0.27, 1.24}, {"robot-b"}, kT0 - 40'000'000'000),
      Box(9, "tv", {0.3, 3.45, 0.72}, {0.9, 3.57, 1.12}),
      Box(10, "dining table", {0, 3, 0}, {1.2, 3.6, 0.72}),
      Box(11, "mouse", {1.0, 3.1, 0.72}, {1.06, 3.2, 0.76}),
      Box(12, "potted plant", {0.02, 3.3, 0.72}, {0.17, 3.45, 1.0}),
      Box(13, "keyboard", {0.4, 3.1, 0.72}, {0.84, 3.24, 0.75}),
      Box(14, "laptop", {1.2, 0.1, 0.75}, {1.54, 0.34, 0.77}, {"robot-a", "robot-b"},
          kT0 - 12'000'000'000),
  };
}

// robot-a's camera at (0.6, 1.8, 1.2) m looking along +y (towards the desk), level: camera x =
// map +x (right), camera y = map -z (down), camera z = map +y (forward).
inline SE3d OfficeViewpoint() {
  SE3d T = SE3d::Identity();
  Mat3d R;
  R.col(0) = Vec3d(1, 0, 0);
  R.col(1) = Vec3d(0, 0, -1);
  R.col(2) = Vec3d(0, 1, 0);
  T.linear() = R;
  T.translation() = Vec3d(0.6, 1.8, 1.2);
  return T;
}

// The scene rigidly rotated by R_new_old (map frame changes; up becomes R_new_old * z). Oriented
// boxes rotate with it; AABBs are recomputed.
inline std::vector<MapObject> Rotated(const std::vector<MapObject>& objects, const Mat3d& R) {
  std::vector<MapObject> out;
  for (MapObject o : objects) {
    o.centroid_m = R * o.centroid_m;
    o.obb_center_m = R * o.obb_center_m;
    o.R_map_box = R * o.R_map_box;
    const Vec3d h = (o.R_map_box.cwiseAbs() * o.obb_half_extent_m);
    o.aabb_min_m = o.obb_center_m - h;
    o.aabb_max_m = o.obb_center_m + h;
    out.push_back(o);
  }
  return out;
}

}  // namespace loci::query::testing
