// Object observations for ObjectMap tests (object_model_test.cc):
// level rectangles and point grids as the mapper builds them, and fusion options with class
// size priors.
#pragma once

#include <algorithm>
#include <string>

#include "server/map/object_map.h"

namespace loci::server::testing {

// A view of a level rectangle [x0, x1] x [y0, y1] at height z_m, one point per cm (a map-frame
// object observation as the mapper builds it).
inline MapObservation Rect(const std::string& cls, double score, int64_t track, int64_t kf,
                           double x0, double x1, double y0, double y1, double z_m) {
  MapObservation o;
  o.session_row = 1;
  o.keyframe_id = kf;
  o.t_ns = kf * 300'000'000;  // keyframes 0.3 s apart
  o.track_id = track;
  o.class_name = cls;
  o.score = score;
  for (double x = x0; x <= x1 + 1e-9; x += 0.01) {
    for (double y = y0; y <= y1 + 1e-9; y += 0.01) {
      o.points_m.push_back({Eigen::Vector3f(x, y, z_m), 0});
    }
  }
  o.centroid_m = {0.5 * (x0 + x1), 0.5 * (y0 + y1), z_m};
  o.half_size_m = 0.5 * std::max(x1 - x0, y1 - y0);
  return o;
}

inline FusionOptions WithSizes(double class_size_slack) {
  FusionOptions opt;
  opt.max_size_m = {{"laptop", 0.6}, {"dining table", 3.5}, {"tv", 1.8}, {"book", 0.6},
                   {"mouse", 0.25}};
  opt.class_size_slack = class_size_slack;
  return opt;
}

// A view whose points fill the grid lo..hi with the given step per axis (map frame, z up).
inline MapObservation Grid(const std::string& cls, int64_t track, int64_t kf,
                           const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                           const Eigen::Vector3d& step) {
  MapObservation o = Rect(cls, 0.6, track, kf, 0, -1, 0, -1, 0);  // no points yet
  for (double x = lo.x(); x <= hi.x() + 1e-9; x += step.x()) {
    for (double y = lo.y(); y <= hi.y() + 1e-9; y += step.y()) {
      for (double z = lo.z(); z <= hi.z() + 1e-9; z += step.z()) {
        o.points_m.push_back({Eigen::Vector3f(x, y, z), 0});
      }
    }
  }
  o.centroid_m = 0.5 * (lo + hi);
  o.half_size_m = 0.5 * (hi - lo).maxCoeff();
  return o;
}

}  // namespace loci::server::testing
