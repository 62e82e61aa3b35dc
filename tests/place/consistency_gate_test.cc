// A loop or merge hypothesis is accepted only after 3 verified matches from distinct keyframes
// agree on the relative transform; a disagreeing one restarts the count.
#include "server/place/consistency_gate.h"

#include <gtest/gtest.h>

#include <numbers>

namespace loci::place {
namespace {

SE3d Pose(double x_m, double yaw_deg) {
  return MakeSE3(Vec3d(x_m, 0.5, 0.0),
                 Quatd(Eigen::AngleAxisd(yaw_deg * std::numbers::pi / 180, Vec3d::UnitZ())));
}

using Verdict = ConsistencyGate::Verdict;

TEST(ConsistencyGateTest, TwoAgreeingMatchesAreNotEnoughThreeAre) {
  ConsistencyGate gate(ConsistencyOptions{});  // 3 matches, 0.10 m, 3 deg
  EXPECT_EQ(gate.Add("a|b", 10, Pose(1.00, 30.0)).verdict, Verdict::kPending);
  const auto second = gate.Add("a|b", 11, Pose(1.04, 31.0));
  EXPECT_EQ(second.verdict, Verdict::kPending);
  EXPECT_EQ(second.agreeing, 2);
  const auto third = gate.Add("a|b", 12, Pose(0.98, 29.5));
  ASSERT_EQ(third.verdict, Verdict::kAccepted);
  EXPECT_EQ(third.agreeing, 3);
  EXPECT_NEAR(third.T_x_y.translation().x(), (1.00 + 1.04 + 0.98) / 3, 1e-9);
  EXPECT_NEAR(RotationAngleRad(Pose(0, 0).inverse() * third.T_x_y) * 180 / std::numbers::pi, 30.17,
              0.01);
  EXPECT_EQ(gate.Pending("a|b"), 0);  // accepted: the hypothesis starts over
}

TEST(ConsistencyGateTest, ADisagreeingMatchRestartsTheCount) {
  ConsistencyGate gate(ConsistencyOptions{});
  gate.Add("a|b", 1, Pose(1.0, 30));
  gate.Add("a|b", 2, Pose(1.0, 30));
  // 5 deg off (translation agrees): resets, and only counts itself.
  const auto wrong = gate.Add("a|b", 3, Pose(1.0, 35));
  EXPECT_EQ(wrong.verdict, Verdict::kReset);
  EXPECT_EQ(wrong.agreeing, 1);
  // 0.2 m off: resets again.
  EXPECT_EQ(gate.Add("a|b", 4, Pose(1.2, 35)).verdict, Verdict::kReset);
  // The earlier, correct transform needs 3 fresh agreeing matches.
  EXPECT_EQ(gate.Add("a|b", 5, Pose(1.0, 30)).verdict, Verdict::kReset);
  EXPECT_EQ(gate.Add("a|b", 6, Pose(1.0, 30)).verdict, Verdict::kPending);
  EXPECT_EQ(gate.Add("a|b", 7, Pose(1.0, 30)).verdict, Verdict::kAccepted);
}

TEST(ConsistencyGateTest, TheSameKeyframeCountsOnce) {
  ConsistencyGate gate(ConsistencyOptions{});
  gate.Add("a|b", 1, Pose(1.0, 30));
  gate.Add("a|b", 2, Pose(1.0, 30));
  const auto again = gate.Add("a|b", 2, Pose(1.0, 30));
  EXPECT_EQ(again.verdict, Verdict::kDuplicate);
  EXPECT_EQ(again.agreeing, 2);
  EXPECT_EQ(gate.Add("a|b", 3, Pose(1.0, 30)).verdict, Verdict::kAccepted);
}

TEST(ConsistencyGateTest, HypothesesAreCountedApart) {
  ConsistencyGate gate(ConsistencyOptions{});
  gate.Add("a|b", 1, Pose(1.0, 30));
  gate.Add("a|c", 2, Pose(-3.0, 90));
  gate.Add("a|b", 3, Pose(1.0, 30));
  EXPECT_EQ(gate.Pending("a|b"), 2);
  EXPECT_EQ(gate.Pending("a|c"), 1);
  gate.Clear("a|b");
  EXPECT_EQ(gate.Pending("a|b"), 0);
}

TEST(ConsistencyGateTest, MinMatchesIsConfigurable) {
  ConsistencyOptions o;
  o.min_matches = 1;  // CCM-SLAM's policy: one match merges
  ConsistencyGate gate(o);
  EXPECT_EQ(gate.Add("a|b", 1, Pose(1.0, 30)).verdict, Verdict::kAccepted);
}

TEST(MeanTransformTest, AveragesTranslationAndRotation) {
  const SE3d m = MeanTransform({Pose(0.0, 10), Pose(2.0, 20)});
  EXPECT_NEAR(m.translation().x(), 1.0, 1e-12);
  EXPECT_NEAR(RotationAngleRad(m) * 180 / std::numbers::pi, 15.0, 1e-9);
}

}  // namespace
}  // namespace loci::place
