#include "server/place/dense_refinement.h"

#include <cmath>
#include <limits>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>

namespace loci::place {
namespace {

// The camera of an image resized by `scale` (pixel centres stay on the same rays).
PinholeCamera Scaled(const PinholeCamera& c, double scale) {
  PinholeCamera s = c;
  s.fx = c.fx * scale;
  s.fy = c.fy * scale;
  s.cx = (c.cx + 0.5) * scale - 0.5;
  s.cy = (c.cy + 0.5) * scale - 0.5;
  s.width_px = static_cast<int>(std::lround(c.width_px * scale));
  s.height_px = static_cast<int>(std::lround(c.height_px * scale));
  return s;
}

cv::Mat CvK(const PinholeCamera& c) {
  cv::Mat K;
  cv::eigen2cv(c.K(), K);
  return K;
}

}  // namespace

DenseFrame MakeDenseFrame(const cv::Mat& bgr, const cv::Mat& depth_m, const PinholeCamera& camera,
                          const DenseOptions& o) {
  DenseFrame f;
  f.camera = Scaled(camera, o.scale);
  const cv::Size size(f.camera.width_px, f.camera.height_px);
  cv::Mat grey;
  if (bgr.channels() == 3) {
    cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  } else {
    grey = bgr;
  }
  if (size == grey.size()) {
    f.grey = grey.clone();
    f.depth_m = depth_m.clone();
  } else {
    cv::resize(grey, f.grey, size, 0, 0, cv::INTER_AREA);
    cv::resize(depth_m, f.depth_m, size, 0, 0, cv::INTER_NEAREST);  // never blend across edges
  }
  const float nan = std::numeric_limits<float>::quiet_NaN();
  f.depth_m.setTo(nan, (f.depth_m < o.min_depth_m) | (f.depth_m > o.max_depth_m));
  return f;
}

std::optional<SE3d> DenseRefiner::Refine(const DenseFrame& a, const DenseFrame& b,
                                         const SE3d& T_a_b) {
  if (a.grey.empty() || b.grey.empty() || a.grey.size() != b.grey.size()) return std::nullopt;
  const DenseOptions& o = options_;
  const cv::Mat K = CvK(a.camera);
  if (odometry_.empty()) {
    // Coarse-to-fine: levels of the image pyramid, iterations per level (finest first).
    const std::vector<int> iterations{7, 7, 7, 10};
    odometry_ = cv::rgbd::RgbdICPOdometry::create(
        K, static_cast<float>(o.min_depth_m), static_cast<float>(o.max_depth_m),
        static_cast<float>(o.max_depth_diff_m), /*maxPointsPart=*/0.07f,
        std::vector<int>(iterations.begin(), iterations.begin() + o.levels));
  } else {
    odometry_->setCameraMatrix(K);  // its normal estimator is rebuilt only if K changed
  }
  cv::Mat init, Rt;
  const Eigen::Matrix4d T = T_a_b.matrix();
  cv::eigen2cv(T, init);
  // OpenCV's Rt carries the source frame's points into the destination's: source b, target a.
  if (!odometry_->compute(b.grey, b.depth_m, cv::Mat(), a.grey, a.depth_m, cv::Mat(), Rt, init)) {
    return std::nullopt;
  }
  Eigen::Matrix4d refined;
  cv::cv2eigen(Rt, refined);
  SE3d out = SE3d::Identity();
  out.matrix() = refined;
  if (!IsFinite(out)) return std::nullopt;
  const SE3d correction = T_a_b.inverse() * out;
  if (correction.translation().norm() > o.max_correction_m ||
      RotationAngleRad(correction) > o.max_correction_rad) {
    return std::nullopt;
  }
  // Re-orthonormalise the rotation the solver accumulated.
  out.linear() = Eigen::Quaterniond(out.linear()).normalized().toRotationMatrix();
  return out;
}

std::optional<SE3d> RefineDense(const DenseFrame& a, const DenseFrame& b, const SE3d& T_a_b,
                                const DenseOptions& options) {
  return DenseRefiner(options).Refine(a, b, T_a_b);
}

}  // namespace loci::place
