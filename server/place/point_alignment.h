// Rigid alignment of matched 3D points from two depth images, weighted by how depth cameras
// err: little across the viewing ray (the pixel's position), much along it (depth noise that
// grows with the square of the depth). Gauss-Newton on
//   sum_k r_k^T C_k^-1 r_k,  r_k = p_a_k - T_a_b * p_b_k,  C_k = S_a_k + R_a_b S_b_k R_a_b^T
// with S = sigma_ray^2 * d d^T + sigma_lateral^2 * (I - d d^T) for the unit ray d of a point.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "common/se3.h"

namespace loci::place {

// Noise of a depth camera's points.
struct PointNoise {
  double focal_px = 500.0;  // focal length, px
  // Depth noise sigma_z = depth_sigma_m_per_m2 * z^2, floored at min_depth_sigma_m.
  double depth_sigma_m_per_m2 = 0.0025;
  double min_depth_sigma_m = 0.002;
};

// Covariance of a point p (camera frame, m) whose pixel has position noise sigma_px.
Eigen::Matrix3d PointCovariance(const Eigen::Vector3d& p, double sigma_px, const PointNoise& noise);

// How well the points determine the refined T_a_b.
struct AlignmentFit {
  // Gauss-Newton information J^T W J at the estimate, for a left perturbation
  // T <- exp(delta) T with delta = (rotation vector, translation).
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
  double chi2 = 0;  // sum of r^T W r over the pairs
  int pairs = 0;
  // The estimate's rotation standard deviation along its weakest direction under the noise
  // model, rad: the square root of the largest eigenvalue of the rotation block of
  // information^-1. A cluster of points on one small patch turns and shifts together along a
  // direction it cannot see. Not scaled by how well the residuals fit (chi2): a sensor noisier
  // than the model, or unrectified rolling-shutter frames, would widen every match alike.
  double rotation_sigma_rad = 0;
};

// Refines T_a_b (in place) from point pairs p_a[k] ~ T_a_b * p_b[k] with covariances cov_a[k]
// and cov_b[k] in their own frames; `iterations` Gauss-Newton steps at most. Returns the fit at
// the final estimate (zero when there are fewer than 3 pairs).
AlignmentFit RefineAlignment(const std::vector<Eigen::Vector3d>& p_a,
                             const std::vector<Eigen::Vector3d>& p_b,
                             const std::vector<Eigen::Matrix3d>& cov_a,
                             const std::vector<Eigen::Matrix3d>& cov_b, int iterations,
                             SE3d* T_a_b);

}  // namespace loci::place
