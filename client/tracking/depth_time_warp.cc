#include "client/tracking/depth_time_warp.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

namespace loci {

namespace {
constexpr double kCrackAgreement = 0.02;  // neighbours filling a crack agree within 2 %
}  // namespace

void FillDepthCracks(cv::Mat* depth_u16) {
  const cv::Mat src = depth_u16->clone();
  auto agree = [](uint16_t a, uint16_t b) {
    return a > 0 && b > 0 && std::abs(a - b) <= kCrackAgreement * std::min(a, b);
  };
  for (int v = 1; v + 1 < src.rows; ++v) {
    const uint16_t* up = src.ptr<uint16_t>(v - 1);
    const uint16_t* row = src.ptr<uint16_t>(v);
    const uint16_t* down = src.ptr<uint16_t>(v + 1);
    uint16_t* out = depth_u16->ptr<uint16_t>(v);
    for (int u = 1; u + 1 < src.cols; ++u) {
      if (row[u] != 0) continue;
      if (agree(row[u - 1], row[u + 1])) {
        out[u] = static_cast<uint16_t>((row[u - 1] + row[u + 1] + 1) / 2);
      } else if (agree(up[u], down[u])) {
        out[u] = static_cast<uint16_t>((up[u] + down[u] + 1) / 2);
      }
    }
  }
}

cv::Mat WarpDepthRows(const cv::Mat& depth_u16, double depth_scale, const PinholeCamera& camera,
                      const std::vector<SE3d>& T_new_old_per_row) {
  cv::Mat out(depth_u16.size(), CV_16UC1, cv::Scalar(0));
  if (T_new_old_per_row.size() != static_cast<size_t>(depth_u16.rows)) return out;
  const double max_units = std::numeric_limits<uint16_t>::max();
  for (int v = 0; v < depth_u16.rows; ++v) {
    const uint16_t* row = depth_u16.ptr<uint16_t>(v);
    const SE3d& T_new_old = T_new_old_per_row[v];
    for (int u = 0; u < depth_u16.cols; ++u) {
      if (row[u] == 0) continue;
      const Vec3d p_new = T_new_old * camera.BackProject(u, v, row[u] / depth_scale);
      const std::optional<Eigen::Vector2d> uv = camera.Project(p_new);
      if (!uv) continue;
      const int un = static_cast<int>(std::lround(uv->x()));
      const int vn = static_cast<int>(std::lround(uv->y()));
      if (un < 0 || vn < 0 || un >= out.cols || vn >= out.rows) continue;
      const double units = std::min(max_units, std::round(p_new.z() * depth_scale));
      if (units < 1) continue;
      uint16_t& d = out.at<uint16_t>(vn, un);
      if (d == 0 || units < d) d = static_cast<uint16_t>(units);
    }
  }
  FillDepthCracks(&out);
  return out;
}

cv::Mat WarpDepth(const cv::Mat& depth_u16, double depth_scale, const PinholeCamera& camera,
                  const SE3d& T_new_old) {
  return WarpDepthRows(depth_u16, depth_scale, camera,
                       std::vector<SE3d>(static_cast<size_t>(depth_u16.rows), T_new_old));
}

void AlignDepthToColourTime(const Tracker& tracker, int64_t depth_t_ns, int64_t rgb_t_ns,
                            cv::Mat* depth_u16) {
  const TrackerOptions& o = tracker.options();
  if (!o.align_depth_time || depth_t_ns == rgb_t_ns || depth_t_ns == 0) return;
  const std::optional<SE3d> T_rgb_depth = tracker.PredictedMotion(depth_t_ns, rgb_t_ns);
  if (T_rgb_depth) *depth_u16 = WarpDepth(*depth_u16, o.depth_scale, o.camera, *T_rgb_depth);
}

}  // namespace loci
