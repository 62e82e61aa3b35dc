#include "server/place/point_alignment.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace loci::place {
namespace {

Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d s;
  s << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return s;
}

// exp of a small twist (rotation vector w, translation v), applied on the left.
SE3d ExpLeft(const Eigen::Matrix<double, 6, 1>& delta) {
  SE3d T = SE3d::Identity();
  const Eigen::Vector3d w = delta.head<3>();
  if (w.norm() > 1e-12) T.linear() = Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix();
  T.translation() = delta.tail<3>();
  return T;
}

// The normal equations of the residuals r_k = p_a_k - T p_b_k at T.
struct NormalEquations {
  Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
  double chi2 = 0;
};

NormalEquations Linearise(const std::vector<Eigen::Vector3d>& p_a,
                          const std::vector<Eigen::Vector3d>& p_b,
                          const std::vector<Eigen::Matrix3d>& cov_a,
                          const std::vector<Eigen::Matrix3d>& cov_b, const SE3d& T_a_b) {
  NormalEquations n;
  const Eigen::Matrix3d R = T_a_b.linear();
  for (size_t k = 0; k < p_a.size(); ++k) {
    const Eigen::Vector3d q = T_a_b * p_b[k];
    const Eigen::Vector3d r = p_a[k] - q;
    const Eigen::Matrix3d W = (cov_a[k] + R * cov_b[k] * R.transpose()).inverse();
    Eigen::Matrix<double, 3, 6> J;  // d r / d delta for T <- exp(delta) * T
    J << Skew(q), -Eigen::Matrix3d::Identity();
    n.H += J.transpose() * W * J;
    n.g += J.transpose() * W * r;
    n.chi2 += r.dot(W * r);
  }
  return n;
}

double RotationSigmaRad(const Eigen::Matrix<double, 6, 6>& H) {
  const Eigen::Matrix<double, 6, 6> cov = H.ldlt().solve(Eigen::Matrix<double, 6, 6>::Identity());
  if (!cov.allFinite()) return M_PI;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov.topLeftCorner<3, 3>());
  return std::sqrt(std::max(0.0, eig.eigenvalues().maxCoeff()));
}

}  // namespace

Eigen::Matrix3d PointCovariance(const Eigen::Vector3d& p, double sigma_px,
                                const PointNoise& noise) {
  const double z = p.z();
  const double sigma_ray = std::max(noise.min_depth_sigma_m, noise.depth_sigma_m_per_m2 * z * z);
  const double sigma_lat = z * sigma_px / noise.focal_px;
  const Eigen::Vector3d d = p.normalized();
  const Eigen::Matrix3d along = d * d.transpose();
  return sigma_ray * sigma_ray * along +
         sigma_lat * sigma_lat * (Eigen::Matrix3d::Identity() - along);
}

AlignmentFit RefineAlignment(const std::vector<Eigen::Vector3d>& p_a,
                             const std::vector<Eigen::Vector3d>& p_b,
                             const std::vector<Eigen::Matrix3d>& cov_a,
                             const std::vector<Eigen::Matrix3d>& cov_b, int iterations,
                             SE3d* T_a_b) {
  AlignmentFit fit;
  if (p_a.size() < 3) return fit;
  for (int it = 0; it < iterations; ++it) {
    const NormalEquations n = Linearise(p_a, p_b, cov_a, cov_b, *T_a_b);
    const Eigen::Matrix<double, 6, 1> delta = n.H.ldlt().solve(-n.g);
    if (!delta.allFinite()) break;
    *T_a_b = ExpLeft(delta) * *T_a_b;
    if (delta.norm() < 1e-9) break;
  }
  const NormalEquations n = Linearise(p_a, p_b, cov_a, cov_b, *T_a_b);
  fit.information = n.H;
  fit.chi2 = n.chi2;
  fit.pairs = static_cast<int>(p_a.size());
  fit.rotation_sigma_rad = RotationSigmaRad(n.H);
  return fit;
}

}  // namespace loci::place
