#include "common/trajectory_eval.h"

#include <random>

#include <gtest/gtest.h>

#include "common/tum_io.h"

namespace loci {
namespace {

// A smooth hand-held-like ground truth at 100 Hz over 10 s.
Trajectory MakeGroundTruth() {
  Trajectory gt;
  for (int i = 0; i < 1000; ++i) {
    const double t = i * 0.01;
    const Vec3d p(0.5 * std::sin(0.6 * t), 0.3 * std::cos(0.4 * t), 1.0 + 0.1 * t);
    const Quatd q(Eigen::AngleAxisd(0.3 * std::sin(t), Vec3d::UnitZ()) *
                  Eigen::AngleAxisd(0.2 * t, Vec3d::UnitY()));
    gt.push_back({1'000'000'000'000LL + i * 10'000'000LL, MakeSE3(p, q)});
  }
  return gt;
}

TEST(TrajectoryEval, AteOfRigidlyMovedTrajectoryIsZero) {
  const Trajectory gt = MakeGroundTruth();
  const SE3d T_est_gt = SE3FromTum(3.0, -1.0, 0.5, 0.2, -0.1, 0.4, 0.88);
  Trajectory est;
  for (size_t i = 0; i < gt.size(); i += 3) {  // 33 Hz with a 2 ms stamp offset
    est.push_back({gt[i].t_ns + 2'000'000, T_est_gt * gt[i].T_world_cam});
  }
  auto r = ComputeAte(gt, est);
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->pairs, est.size());
  EXPECT_LT(r->trans_m.rmse, 1e-9);
  EXPECT_TRUE(r->T_gt_est.isApprox(T_est_gt.inverse(), 1e-6));
}

TEST(TrajectoryEval, AteRecoversKnownNoise) {
  const Trajectory gt = MakeGroundTruth();
  const SE3d T_est_gt = SE3FromTum(-2.0, 0.5, 1.5, 0.0, 0.3, 0.0, 0.954);
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0.0, 0.01);  // 1 cm per axis
  Trajectory est;
  for (const auto& p : gt) {
    SE3d T = p.T_world_cam;
    T.translation() += Vec3d(n(rng), n(rng), n(rng));
    est.push_back({p.t_ns, T_est_gt * T});
  }
  auto r = ComputeAte(gt, est);
  ASSERT_TRUE(r.ok());
  // E|e|^2 = 3 sigma^2 -> rmse ~ sqrt(3) cm; alignment absorbs a little.
  EXPECT_NEAR(r->trans_m.rmse, std::sqrt(3.0) * 0.01, 0.0015);
  EXPECT_GT(r->trans_m.max, r->trans_m.median);
}

// A camera that only turns in place, with 1 cm of position noise: the positions say nothing
// about the frame's rotation, the orientations do.
TEST(TrajectoryEval, OrientationAlignmentRecoversRotationWherePositionsCannot) {
  std::mt19937 rng(3);
  std::normal_distribution<double> noise_m(0.0, 0.01);
  const SE3d T_est_gt = SE3FromTum(0.3, -0.2, 0.1, 0.1, -0.2, 0.3, 0.92);
  Trajectory gt, est;
  for (int i = 0; i < 300; ++i) {
    const Quatd q(Eigen::AngleAxisd(0.5 * std::sin(0.05 * i), Vec3d::UnitZ()) *
                  Eigen::AngleAxisd(0.3 * std::cos(0.07 * i), Vec3d::UnitX()));
    const SE3d T_world_cam = MakeSE3(Vec3d(1.0, 2.0, 1.5), q);
    gt.push_back({i * 30'000'000LL, T_world_cam});
    SE3d T_est_cam = T_est_gt * T_world_cam;
    T_est_cam.translation() += Vec3d(noise_m(rng), noise_m(rng), noise_m(rng));
    est.push_back({i * 30'000'000LL, T_est_cam});
  }
  auto R_gt_est = OrientationAlignment(gt, est);
  ASSERT_TRUE(R_gt_est.ok()) << R_gt_est.status();
  EXPECT_LT(Eigen::AngleAxisd(*R_gt_est * T_est_gt.linear()).angle(), 1e-9);
  auto ate = ComputeAte(gt, est);
  ASSERT_TRUE(ate.ok());
  EXPECT_GT(Eigen::AngleAxisd(ate->T_gt_est.linear() * T_est_gt.linear()).angle(), 0.05)
      << "positions alone should not pin the rotation here";
  // The whole-pose alignment: that rotation, and the translation the noisy positions average to.
  auto T_gt_est = AlignByOrientations(gt, est);
  ASSERT_TRUE(T_gt_est.ok()) << T_gt_est.status();
  const SE3d residual = *T_gt_est * T_est_gt;
  EXPECT_LT(Eigen::AngleAxisd(residual.linear()).angle(), 1e-9);
  EXPECT_LT(residual.translation().norm(), 0.003);  // 1 cm noise over 300 poses
}

TEST(TrajectoryEval, AteRejectsDisjointStamps) {
  const Trajectory gt = MakeGroundTruth();
  Trajectory est = gt;
  for (auto& p : est) p.t_ns += 100'000'000'000LL;
  EXPECT_FALSE(ComputeAte(gt, est).ok());
}

TEST(TrajectoryEval, RpeOfKnownDrift) {
  const Trajectory gt = MakeGroundTruth();
  // The estimate is rigidly moved (RPE must ignore that) and drifts 2 cm/s along its x.
  const SE3d T_est_gt = SE3FromTum(1.0, 2.0, 3.0, 0.0, 0.0, 0.38, 0.925);
  Trajectory est;
  for (const auto& p : gt) {
    const double t = (p.t_ns - gt.front().t_ns) * 1e-9;
    SE3d T = T_est_gt * p.T_world_cam;
    T.translation() += T_est_gt.rotation() * Vec3d(0.02 * t, 0, 0);
    est.push_back({p.t_ns, T});
  }
  auto r = ComputeRpe(gt, est);
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_NEAR(r->trans_m.rmse, 0.02, 1e-6);
  EXPECT_NEAR(r->rot_rad.rmse, 0.0, 1e-6);  // acos near 1 resolves ~1e-8
  EXPECT_GT(r->pairs, 800u);
}

TEST(TrajectoryEval, ShippedSampleGroundTruthAgainstItself) {
  auto seq = LoadTumSequence(std::string(LOCI_SOURCE_DIR) + "/tests/data/tum_fr1_rpy_sample");
  ASSERT_TRUE(seq.ok());
  auto r = ComputeAte(seq->groundtruth, seq->groundtruth);
  ASSERT_TRUE(r.ok());
  EXPECT_LT(r->trans_m.rmse, 1e-9);
  EXPECT_EQ(r->pairs, seq->groundtruth.size());
}

TEST(TrajectoryEval, ErrorStatsMatchNumpy) {
  const ErrorStats s = ComputeErrorStats({1, 2, 3, 4});
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_DOUBLE_EQ(s.median, 2.5);
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(7.5));
  EXPECT_DOUBLE_EQ(s.std, std::sqrt(1.25));
  EXPECT_DOUBLE_EQ(s.max, 4);
}

}  // namespace
}  // namespace loci
