// Constant-velocity Kalman filter on an image box (paper 000, eqs. 1-7, as in DeepSORT).
// State x = [cx, cy, a, h, vcx, vcy, va, vh]: box centre (px), aspect a = w / h, height (px)
// and their velocities per update step. Measurement z = [cx, cy, a, h]. Noise is scaled by the
// box height so the filter behaves the same for near and far objects.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace loci::detection {

class KalmanBoxFilter {
 public:
  using State = Eigen::Matrix<double, 8, 1>;
  using Cov = Eigen::Matrix<double, 8, 8>;
  using Meas = Eigen::Matrix<double, 4, 1>;

  // std_weight_position / std_weight_velocity: noise std as a fraction of the box height
  // (DeepSORT: 1/20 and 1/160), floored at min_position_std_px / min_velocity_std_px (pixels,
  // pixels per step) so small boxes still allow for camera ego-motion between keyframes.
  explicit KalmanBoxFilter(const cv::Rect2f& box_px, double std_weight_position = 1.0 / 20,
                           double std_weight_velocity = 1.0 / 160, double min_position_std_px = 0.0,
                           double min_velocity_std_px = 0.0);

  // Eqs. 1-2: x = A x, P = A P A^T + Q (one step).
  void Predict();
  // Eqs. 3-7 with measurement `box_px`.
  void Update(const cv::Rect2f& box_px);
  // Squared Mahalanobis distance of `box_px` to the predicted measurement (4 dof; the 95 %
  // chi-square gate is 9.4877).
  double MahalanobisSq(const cv::Rect2f& box_px) const;

  cv::Rect2f Box() const;  // current estimate as x, y, w, h in pixels
  const State& state() const { return x_; }
  const Cov& covariance() const { return P_; }

  static Meas ToMeas(const cv::Rect2f& box_px);

 private:
  Eigen::Matrix4d MeasurementNoise() const;

  double PosStd(double scale) const;
  double VelStd(double scale) const;

  double w_pos_, w_vel_, min_pos_px_, min_vel_px_;
  State x_;
  Cov P_;
};

}  // namespace loci::detection
