#include "server/map/visibility.h"

#include <algorithm>
#include <cmath>

namespace loci::server {
namespace {

double Iou(const cv::Rect2f& a, const cv::Rect2f& b) {
  const float inter = (a & b).area();
  const float uni = a.area() + b.area() - inter;
  return uni > 0 ? inter / uni : 0.0;
}

}  // namespace

cv::Mat SubsampleDepth(const cv::Mat& depth_m, int stride) {
  if (stride <= 1) return depth_m.clone();
  cv::Mat out((depth_m.rows + stride - 1) / stride, (depth_m.cols + stride - 1) / stride, CV_32FC1);
  for (int v = 0; v < out.rows; ++v) {
    for (int u = 0; u < out.cols; ++u) out.at<float>(v, u) = depth_m.at<float>(v * stride, u * stride);
  }
  return out;
}

bool ExpectedInView(const std::vector<Eigen::Vector3d>& sample_m, double size_m,
                    const KeyframeView& view, const VisibilityOptions& o) {
  if (sample_m.empty() || view.camera == nullptr || view.depth_m == nullptr) return false;
  const cv::Mat& depth = *view.depth_m;
  const double allowance = std::min(size_m, 0.5);
  int visible = 0;
  float u_lo = 1e9f, v_lo = 1e9f, u_hi = -1e9f, v_hi = -1e9f;
  for (const Eigen::Vector3d& p_m : sample_m) {
    const Eigen::Vector3d p = view.T_kf_map * p_m;
    if (!(p.z() > 0.1 && p.z() <= o.max_depth_m)) continue;
    const auto px = view.camera->Project(p);
    if (!px) continue;
    const int u = static_cast<int>(std::lround(px->x())), v = static_cast<int>(std::lround(px->y()));
    if (u < o.border_px || v < o.border_px || u >= view.camera->width_px - o.border_px ||
        v >= view.camera->height_px - o.border_px) {
      continue;
    }
    const int stride = std::max(1, view.depth_stride);
    const int du = std::min(depth.cols - 1, (u + stride / 2) / stride);
    const int dv = std::min(depth.rows - 1, (v + stride / 2) / stride);
    const float d = depth.at<float>(dv, du);
    if (!(d > 0)) continue;  // unknown depth: no evidence either way
    if (d < p.z() - (o.occlusion_tol_m + o.occlusion_tol_rel * p.z() + allowance)) continue;
    ++visible;
    u_lo = std::min<float>(u_lo, u);
    u_hi = std::max<float>(u_hi, u);
    v_lo = std::min<float>(v_lo, v);
    v_hi = std::max<float>(v_hi, v);
  }
  if (visible < o.min_visible_fraction * static_cast<double>(sample_m.size())) return false;
  if (std::max(u_hi - u_lo, v_hi - v_lo) < o.min_projected_px) return false;
  if (view.detections != nullptr) {
    const cv::Rect2f projected(u_lo, v_lo, u_hi - u_lo, v_hi - v_lo);
    for (const Detection2D& d : *view.detections) {
      if (Iou(d.box_px, projected) >= o.excuse_iou) return false;
    }
  }
  return true;
}

}  // namespace loci::server
