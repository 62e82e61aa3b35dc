// CompareRelativePoses (common/relative_pose_eval.h): a camera turning about its vertical axis at
// 60 deg/s and moving 0.2 m/s, sampled at 100 Hz; relative poses measured exactly, with a known
// error, between instants the truth does not cover, and with an image clock offset.
#include "common/relative_pose_eval.h"

#include <gtest/gtest.h>

#include <cmath>

namespace loci {
namespace {

SE3d TruePose(double t_s) {
  SE3d T = SE3d::Identity();
  T.linear() = Eigen::AngleAxisd(t_s * M_PI / 3, Vec3d::UnitY()).toRotationMatrix();
  T.translation() = Vec3d(0.2 * t_s, 0, 0.05 * t_s);
  return T;
}

Trajectory Truth() {
  Trajectory gt;
  for (int i = 0; i <= 300; ++i) gt.push_back({i * 10'000'000LL, TruePose(0.01 * i)});
  return gt;
}

RelativePoseSample Exact(double a_s, double b_s) {
  return {static_cast<int64_t>(a_s * 1e9), static_cast<int64_t>(b_s * 1e9),
          TruePose(a_s).inverse() * TruePose(b_s)};
}

TEST(RelativePoseEval, AnExactMeasurementIsZeroAndAKnownErrorIsFound) {
  RelativePoseSample off = Exact(0.5, 2.5);
  SE3d E = SE3d::Identity();  // 2 deg about a tilted axis and 3 cm
  E.linear() = Eigen::AngleAxisd(2 * M_PI / 180, Vec3d(1, 1, 0).normalized()).toRotationMatrix();
  E.translation() = Vec3d(0.03, 0, 0);
  off.T_a_b = off.T_a_b * E;
  const RelativePoseErrors r =
      CompareRelativePoses(Truth(), {Exact(0.505, 2.0), off}, 0, 20'000'000);
  ASSERT_EQ(r.rot_deg.size(), 2u);
  EXPECT_NEAR(r.rot_deg[0], 0, 1e-6);  // 0.505 s lies between two samples: interpolated
  EXPECT_NEAR(r.trans_m[0], 0, 1e-9);
  EXPECT_NEAR(r.rot_deg[1], 2.0, 1e-6);
  EXPECT_NEAR(r.trans_m[1], 0.03, 1e-9);
}

TEST(RelativePoseEval, InstantsOutsideTheTruthAreNaN) {
  const RelativePoseErrors r =
      CompareRelativePoses(Truth(), {Exact(1.0, 3.5), Exact(-0.1, 1.0)}, 0, 20'000'000);
  EXPECT_TRUE(std::isnan(r.rot_deg[0]) && std::isnan(r.trans_m[0]));
  EXPECT_TRUE(std::isnan(r.rot_deg[1]));
}

TEST(RelativePoseEval, TheOffsetReadsTheTruthLater) {
  // Stamped 10 ms early: read at the stamps, the truth's relative translation is expressed in a
  // camera turned 0.6 deg less.
  RelativePoseSample s = Exact(1.01, 2.01);
  s.a_t_ns -= 10'000'000;
  s.b_t_ns -= 10'000'000;
  const RelativePoseErrors at_offset = CompareRelativePoses(Truth(), {s}, 10'000'000, 20'000'000);
  EXPECT_NEAR(at_offset.rot_deg[0], 0, 1e-4);
  EXPECT_NEAR(at_offset.trans_m[0], 0, 1e-6);
  EXPECT_GT(CompareRelativePoses(Truth(), {s}, 0, 20'000'000).trans_m[0], 1e-3);
}

}  // namespace
}  // namespace loci
