// RefineAlignment's fit (server/place/point_alignment.h): how well matched depth points fix a
// relative pose. Points seen by a depth camera 2 m away, moved by a known transform, with
// depth-camera noise drawn from the same model the fit assumes.
#include "server/place/point_alignment.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace loci::place {
namespace {

struct FitResult {
  AlignmentFit fit;
  double error_deg = 0;
};

// n points on a wall 2 m in front of camera b, spread over half_width_m x half_width_m, seen
// from camera a (a small turn and shift away); noise `noise_mul` x the model's.
FitResult Fit(double half_width_m, double noise_mul, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> across(-half_width_m, half_width_m);
  std::normal_distribution<double> unit(0.0, 1.0);
  SE3d T_a_b = SE3d::Identity();
  T_a_b.linear() = Eigen::AngleAxisd(0.05, Eigen::Vector3d(0.2, 1, 0.1).normalized())
                       .toRotationMatrix();
  T_a_b.translation() = Eigen::Vector3d(0.1, -0.05, 0.08);
  const PointNoise noise;
  std::vector<Eigen::Vector3d> p_a, p_b;
  std::vector<Eigen::Matrix3d> cov_a, cov_b;
  for (int k = 0; k < 150; ++k) {
    const Eigen::Vector3d b(across(rng), across(rng), 2.0 + 0.1 * across(rng));
    const Eigen::Vector3d a = T_a_b * b;
    cov_b.push_back(PointCovariance(b, 1.0, noise));
    cov_a.push_back(PointCovariance(a, 1.0, noise));
    const Eigen::Matrix3d L = cov_a.back().llt().matrixL();
    const Eigen::Matrix3d L_b = cov_b.back().llt().matrixL();
    p_b.push_back(b + noise_mul * L_b * Eigen::Vector3d(unit(rng), unit(rng), unit(rng)));
    p_a.push_back(a + noise_mul * L * Eigen::Vector3d(unit(rng), unit(rng), unit(rng)));
  }
  SE3d estimate = SE3d::Identity();
  estimate.translation() = T_a_b.translation();
  FitResult r;
  r.fit = RefineAlignment(p_a, p_b, cov_a, cov_b, 10, &estimate);
  r.error_deg = Eigen::AngleAxisd(T_a_b.linear().transpose() * estimate.linear()).angle() *
                180.0 / M_PI;
  return r;
}

TEST(PointAlignment, PointsOnOnePatchFixTheRotationLessThanPointsAcrossTheView) {
  const FitResult wide = Fit(1.0, 1.0, 1), patch = Fit(0.1, 1.0, 1);
  std::printf("rotation sigma: %.3f deg across the view, %.3f deg on a 0.2 m patch\n",
              wide.fit.rotation_sigma_rad * 180 / M_PI, patch.fit.rotation_sigma_rad * 180 / M_PI);
  EXPECT_EQ(wide.fit.pairs, 150);
  EXPECT_GT(patch.fit.rotation_sigma_rad, 5 * wide.fit.rotation_sigma_rad);
  // Residuals as the model says: chi2 about 3 per pair, and the error within a few sigmas.
  EXPECT_NEAR(wide.fit.chi2 / wide.fit.pairs, 3.0, 1.0);
  EXPECT_LT(wide.error_deg, 4 * wide.fit.rotation_sigma_rad * 180 / M_PI);
}

// Noisier points than the model says show in chi2, not in the sigma: the sigma is the geometry's.
TEST(PointAlignment, ResidualsWorseThanTheModelShowInChi2) {
  const FitResult as_model = Fit(1.0, 1.0, 2), worse = Fit(1.0, 3.0, 2);
  EXPECT_GT(worse.fit.chi2, 6 * as_model.fit.chi2);  // about 9x
  EXPECT_NEAR(worse.fit.rotation_sigma_rad / as_model.fit.rotation_sigma_rad, 1.0, 0.1);
}

}  // namespace
}  // namespace loci::place
