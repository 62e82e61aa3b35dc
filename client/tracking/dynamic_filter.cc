#include "client/tracking/dynamic_filter.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace loci {

double DynamicFilter::ClassWeight(const std::string& class_name) const {
  auto it = opt_.dynamic.class_weights.find(class_name);
  return it == opt_.dynamic.class_weights.end() ? 0.0 : it->second;
}

void DynamicFilter::AssignWeights(const std::vector<Detection2D>& detections,
                                  OrbFrame* frame) const {
  std::fill(frame->class_weight.begin(), frame->class_weight.end(), -1.f);
  for (const Detection2D& d : detections) {
    const float w = static_cast<float>(ClassWeight(d.class_name));
    const cv::Rect mask_rect = MaskRect(d.box_px, frame->width_px, frame->height_px);
    const bool has_mask = !d.mask.empty() && d.mask.cols == mask_rect.width &&
                          d.mask.rows == mask_rect.height && d.mask.type() == CV_8UC1;
    for (size_t i = 0; i < frame->size(); ++i) {
      const cv::Point2f& pt = frame->keypoints[i].pt;
      if (!d.box_px.contains(pt)) continue;
      if (has_mask) {
        const int mx = static_cast<int>(pt.x) - mask_rect.x;
        const int my = static_cast<int>(pt.y) - mask_rect.y;
        if (mx < 0 || my < 0 || mx >= mask_rect.width || my >= mask_rect.height ||
            d.mask.at<uint8_t>(my, mx) == 0) {
          continue;
        }
      }
      frame->class_weight[i] = std::max(frame->class_weight[i], w);
    }
  }
}

double DynamicFilter::Threshold(float weight) const {
  const double w = weight < 0 ? opt_.dynamic.weight_outside_boxes : std::max(0.0f, weight);
  if (w <= 1e-6) return std::numeric_limits<double>::infinity();
  return opt_.dynamic.threshold / w;
}

double DynamicFilter::DynamicValue(const Eigen::Vector2d& uv_px, double depth_m,
                                   const Vec3d& p_world, const SE3d& T_cam_world, bool has_prev,
                                   const Eigen::Vector2d& prev_uv_px,
                                   const SE3d& T_world_prevcam) const {
  double d1_px = 0.0;
  if (has_prev) {
    // F maps a previous pixel to its epipolar line in the current image.
    const SE3d T_cur_prev = T_cam_world * T_world_prevcam;
    const Mat3d R = T_cur_prev.linear();
    const Vec3d t = T_cur_prev.translation();
    Mat3d tx;
    tx << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
    const Mat3d K = opt_.camera.K();
    const Mat3d Kinv = K.inverse();
    const Mat3d F = Kinv.transpose() * tx * R * Kinv;
    const Vec3d line = F * Vec3d(prev_uv_px.x(), prev_uv_px.y(), 1.0);
    const double norm = std::hypot(line.x(), line.y());
    // A pure rotation has no epipolar geometry (t = 0): fall back to the reprojection-free case.
    if (t.norm() > 1e-4 && norm > 1e-12) {
      d1_px = std::abs(line.dot(Vec3d(uv_px.x(), uv_px.y(), 1.0))) / norm;
    }
  }
  double d2_m = 0.0, sigma_z = 1.0;
  const double z_pred = (T_cam_world * p_world).z();
  if (depth_m > 0 && z_pred > 0) {
    d2_m = z_pred - depth_m;
    sigma_z = opt_.dynamic.depth_sigma_at_1m * std::max(1.0, depth_m * depth_m);
  }
  return std::abs(d1_px) / opt_.dynamic.epipolar_sigma_px + std::abs(d2_m) / sigma_z;
}

}  // namespace loci
