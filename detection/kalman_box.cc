#include "detection/kalman_box.h"

#include <Eigen/Cholesky>
#include <algorithm>

namespace loci::detection {

KalmanBoxFilter::Meas KalmanBoxFilter::ToMeas(const cv::Rect2f& b) {
  const double h = std::max(1e-3f, b.height);
  return {b.x + b.width * 0.5, b.y + b.height * 0.5, b.width / h, h};
}

KalmanBoxFilter::KalmanBoxFilter(const cv::Rect2f& box_px, double std_weight_position,
                                 double std_weight_velocity)
    : w_pos_(std_weight_position), w_vel_(std_weight_velocity) {
  const Meas z = ToMeas(box_px);
  x_.setZero();
  x_.head<4>() = z;
  const double h = z(3);
  State sd;
  sd << 2 * w_pos_ * h, 2 * w_pos_ * h, 1e-2, 2 * w_pos_ * h, 10 * w_vel_ * h, 10 * w_vel_ * h,
      1e-5, 10 * w_vel_ * h;
  P_ = sd.cwiseAbs2().asDiagonal();
}

void KalmanBoxFilter::Predict() {
  const double h = x_(3);
  State sd;
  sd << w_pos_ * h, w_pos_ * h, 1e-2, w_pos_ * h, w_vel_ * h, w_vel_ * h, 1e-5, w_vel_ * h;
  // A = [I I; 0 I]: x_k = x_{k-1} + v (eq. 1), P = A P A^T + Q (eq. 2).
  Cov A = Cov::Identity();
  A.topRightCorner<4, 4>().setIdentity();
  x_ = A * x_;
  P_ = A * P_ * A.transpose();
  P_.diagonal() += sd.cwiseAbs2();
}

Eigen::Matrix4d KalmanBoxFilter::MeasurementNoise() const {
  const double h = x_(3);
  Eigen::Vector4d sd(w_pos_ * h, w_pos_ * h, 1e-1, w_pos_ * h);
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
