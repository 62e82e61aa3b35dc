#include "detection/kalman_box.h"

#include <Eigen/Cholesky>
#include <algorithm>

namespace loci::detection {

KalmanBoxFilter::Meas KalmanBoxFilter::ToMeas(const cv::Rect2f& b) {
  const double h = std::max(1e-3f, b.height);
  return {b.x + b.width * 0.5, b.y + b.height * 0.5, b.width / h, h};
}

double KalmanBoxFilter::PosStd(double scale) const {
  return std::max(scale * w_pos_ * x_(3), scale * min_pos_px_);
}

double KalmanBoxFilter::VelStd(double scale) const {
  return std::max(scale * w_vel_ * x_(3), min_vel_px_);
}

KalmanBoxFilter::KalmanBoxFilter(const cv::Rect2f& box_px, double std_weight_position,
                                 double std_weight_velocity, double min_position_std_px,
                                 double min_velocity_std_px)
    : w_pos_(std_weight_position),
      w_vel_(std_weight_velocity),
      min_pos_px_(min_position_std_px),
      min_vel_px_(min_velocity_std_px) {
  const Meas z = ToMeas(box_px);
  x_.setZero();
  x_.head<4>() = z;
  State sd;
  sd << PosStd(2), PosStd(2), 1e-2, PosStd(2), VelStd(10), VelStd(10), 1e-5, VelStd(10);
  P_ = sd.cwiseAbs2().asDiagonal();
}

void KalmanBoxFilter::Predict() {
  State sd;
  sd << PosStd(1), PosStd(1), 1e-2, PosStd(1), VelStd(1), VelStd(1), 1e-5, VelStd(1);
  // A = [I I; 0 I]: x_k = x_{k-1} + v (eq. 1), P = A P A^T + Q (eq. 2).
  Cov A = Cov::Identity();
  A.topRightCorner<4, 4>().setIdentity();
  x_ = A * x_;
  P_ = A * P_ * A.transpose();
  P_.diagonal() += sd.cwiseAbs2();
}

Eigen::Matrix4d KalmanBoxFilter::MeasurementNoise() const {
  Eigen::Vector4d sd(PosStd(1), PosStd(1), 1e-1, PosStd(1));
  return sd.cwiseAbs2().asDiagonal();
}

void KalmanBoxFilter::Update(const cv::Rect2f& box_px) {
  Eigen::Matrix<double, 4, 8> H = Eigen::Matrix<double, 4, 8>::Zero();
  H.leftCols<4>().setIdentity();
  const Meas y = ToMeas(box_px) - H * x_;                                 // eq. 3
  const Eigen::Matrix4d S = H * P_ * H.transpose() + MeasurementNoise();  // eq. 4
  // eq. 5, K = P H^T S^-1, solved with Cholesky instead of an explicit inverse.
  const Eigen::Matrix<double, 8, 4> K = S.llt().solve(H * P_).transpose();
  x_ += K * y;                          // eq. 6
  P_ = (Cov::Identity() - K * H) * P_;  // eq. 7
  P_ = 0.5 * (P_ + P_.transpose());     // keep symmetric against round-off
}

double KalmanBoxFilter::MahalanobisSq(const cv::Rect2f& box_px) const {
  const Meas y = ToMeas(box_px) - x_.head<4>();
  const Eigen::Matrix4d S = P_.topLeftCorner<4, 4>() + MeasurementNoise();
  return y.dot(S.llt().solve(y));
}

cv::Rect2f KalmanBoxFilter::Box() const {
  const double h = x_(3), w = x_(2) * h;
  return {static_cast<float>(x_(0) - w / 2), static_cast<float>(x_(1) - h / 2),
          static_cast<float>(w), static_cast<float>(h)};
}

}  // namespace loci::detection
