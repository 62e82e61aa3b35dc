#include "common/clock_offset.h"

#include <random>

#include <gtest/gtest.h>

namespace loci {
namespace {

const std::string kSample = std::string(LOCI_SOURCE_DIR) + "/tests/data/tum_fr1_rpy_sample";

// The shipped sample's real ground truth read at each image stamp + delay_ns, in a frame turned
// away from the ground truth's, with 0.2 deg of orientation noise per pose: an estimate whose
// images were stamped delay_ns late.
Trajectory DelayedEstimate(const TumSequence& seq, int64_t delay_ns) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise_rad(0.0, 0.2 * M_PI / 180.0 / std::sqrt(3.0));
  SE3d T_est_gt = SE3d::Identity();
  T_est_gt.linear() = Eigen::AngleAxisd(0.7, Vec3d(0.3, -1.0, 0.2).normalized()).matrix();
  T_est_gt.translation() = Vec3d(0.4, -0.1, 1.2);
  Trajectory est;
  for (const TumFrame& f : seq.frames) {
    const auto T = InterpolatePose(seq.groundtruth, f.rgb_t_ns + delay_ns, 40'000'000);
    if (!T) continue;
    SE3d T_est = T_est_gt * *T;
    const Vec3d w(noise_rad(rng), noise_rad(rng), noise_rad(rng));
    T_est.linear() = T_est.linear() * Eigen::AngleAxisd(w.norm(), w.normalized()).matrix();
    est.push_back({f.rgb_t_ns, T_est});
  }
  return est;
}

TEST(ClockOffset, FindsTheDelayOfImagesStampedLateOnRealGroundTruth) {
  auto seq = LoadTumSequence(kSample);
  ASSERT_TRUE(seq.ok()) << seq.status();
  for (const int64_t delay_ns : {-17'000'000LL, 0LL, 23'000'000LL}) {
    const Trajectory est = DelayedEstimate(*seq, delay_ns);
    ASSERT_GT(est.size(), 40u);
    auto off = EstimateClockOffset(seq->groundtruth, est);
    ASSERT_TRUE(off.ok()) << off.status();
    EXPECT_NEAR(off->offset_ns, delay_ns, 2'000'000) << "delay " << delay_ns;
    EXPECT_LT(off->rms_deg, 0.4);  // the noise alone
    if (delay_ns != 0) {
      EXPECT_GT(off->rms_deg_at_zero, 3 * off->rms_deg);
    }
    auto at = OrientationResidualDeg(seq->groundtruth, est, off->offset_ns);
    ASSERT_TRUE(at.ok());
    EXPECT_NEAR(*at, off->rms_deg, 0.05);  // a shorter pose set than the search's, same figure
  }
}

TEST(ClockOffset, RejectsTooFewPosesAndBadRanges) {
  auto seq = LoadTumSequence(kSample);
  ASSERT_TRUE(seq.ok());
  Trajectory est = DelayedEstimate(*seq, 0);
  est.resize(5);
  EXPECT_FALSE(EstimateClockOffset(seq->groundtruth, est).ok());
  Trajectory outside = DelayedEstimate(*seq, 0);
  for (StampedPose& p : outside) p.t_ns += 3'600'000'000'000LL;  // an hour later
  EXPECT_FALSE(EstimateClockOffset(seq->groundtruth, outside).ok());
  ClockOffsetOptions bad;
  bad.step_ns = 0;
  EXPECT_FALSE(EstimateClockOffset(seq->groundtruth, DelayedEstimate(*seq, 0), bad).ok());
}

}  // namespace
}  // namespace loci
