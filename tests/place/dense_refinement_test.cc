// Dense refinement of verified matches (server/place/dense_refinement.h) against exact truth:
// frames of a synthetic room with Kinect-like depth noise. The refined relative poses are closer
// to the truth than the sparse ones, the solver converges from a few centimetres off, and a
// correction beyond the configured bounds is refused.
#include "server/place/dense_refinement.h"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "server/place/geometric_verification.h"
#include "tests/place/place_test_util.h"

namespace loci::place::testing {
namespace {

DenseFrame Dense(const SyntheticFrame& f, const DenseOptions& o) {
  return MakeDenseFrame(f.bgr, f.depth_m, f.features.camera, o);
}

TEST(DenseRefinement, VerifiedMatchesComeCloserToExactTruth) {
  const std::vector<SyntheticFrame> frames = NoisyRoomFrames();
  ASSERT_EQ(frames.size(), 20u);
  const DenseOptions o;
  ErrorStats sparse, dense;
  int refused = 0;
  for (size_t i = 0; i < frames.size(); ++i) {
    for (size_t j = 0; j + 4 <= i; ++j) {
      const SE3d gt = frames[i].T_world_cam.inverse() * frames[j].T_world_cam;
      if (Deg(RotationAngleRad(gt)) > 25.0) continue;
      const Verification v = VerifyPair(frames[i].features, frames[j].features, VerifyOptions{});
      if (!v.accepted) continue;
      const std::optional<SE3d> refined =
          RefineDense(Dense(frames[i], o), Dense(frames[j], o), v.T_a_b, o);
      refused += !refined;
      sparse.Add(Error(gt, v.T_a_b));
      dense.Add(Error(gt, refined.value_or(v.T_a_b)));
    }
  }
  std::cout << "synthetic, " << sparse.size() << " verified pairs (" << refused
            << " refinements refused): sparse " << sparse.Summary() << "\n  dense " << dense.Summary()
            << "\n";
  ASSERT_GE(sparse.size(), 20u);
  EXPECT_LE(refused, static_cast<int>(sparse.size() / 10));
  EXPECT_LT(dense.MedianT(), sparse.MedianT());
  EXPECT_LT(dense.MedianR(), sparse.MedianR());
  EXPECT_LE(dense.QuantileT(0.9), sparse.QuantileT(0.9));
}

TEST(DenseRefinement, ConvergesFromCentimetresOffAndRefusesCorrectionsBeyondItsBounds) {
  const std::vector<SyntheticFrame> frames = NoisyRoomFrames();
  ASSERT_GE(frames.size(), 2u);
  DenseOptions o;
  const DenseFrame a = Dense(frames[1], o), b = Dense(frames[0], o);
  const SE3d gt = frames[1].T_world_cam.inverse() * frames[0].T_world_cam;
  // 3 cm and 1 deg off the truth.
  const SE3d off = gt * MakeSE3(Vec3d(0.02, -0.015, 0.015),
                                Quatd(Eigen::AngleAxisd(M_PI / 180, Vec3d(1, 1, 0).normalized())));
  const std::optional<SE3d> refined = RefineDense(a, b, off, o);
  ASSERT_TRUE(refined.has_value());
  const PoseError e = Error(gt, *refined);
  std::cout << "from 3 cm, 1 deg off: " << e.t_m * 1000 << " mm, " << e.r_deg << " deg\n";
  EXPECT_LT(e.t_m, 0.01);
  EXPECT_LT(e.r_deg, 0.3);
  // The same solve with a 1 cm bound on the correction: refused, the caller keeps its estimate.
  o.max_correction_m = 0.01;
  EXPECT_FALSE(RefineDense(a, b, off, o).has_value());
  // Images of different sizes cannot be aligned.
  DenseOptions half = o;
  half.scale = 0.25;
  EXPECT_FALSE(RefineDense(a, Dense(frames[0], half), gt, DenseOptions{}).has_value());
}

// The server keeps one refiner per aligner: what it refined before, and a camera that changed
// in between, must not change a result.
TEST(DenseRefinement, AKeptRefinerGivesWhatAFreshOneGives) {
  const std::vector<SyntheticFrame> frames = NoisyRoomFrames();
  const DenseOptions o;
  DenseFrame wider = Dense(frames[1], o);  // the same images as if seen with another lens
  wider.camera.fx *= 1.05;
  wider.camera.fy *= 1.05;
  DenseRefiner kept(o);
  int refined = 0;
  for (size_t i = 4; i < frames.size(); i += 3) {
    const Verification v = VerifyPair(frames[i].features, frames[i - 4].features, VerifyOptions{});
    if (!v.accepted) continue;
    const DenseFrame a = Dense(frames[i], o), b = Dense(frames[i - 4], o);
    // a twice (the second solve reuses what the first set up), then another camera.
    for (const DenseFrame* target : std::vector<const DenseFrame*>{&a, &a, &wider}) {
      const std::optional<SE3d> fresh = RefineDense(*target, b, v.T_a_b, o);
      const std::optional<SE3d> again = kept.Refine(*target, b, v.T_a_b);
      ASSERT_EQ(fresh.has_value(), again.has_value()) << "pair " << i;
      if (!fresh) continue;
      ++refined;
      EXPECT_EQ(fresh->matrix(), again->matrix()) << "pair " << i;
    }
  }
  EXPECT_GE(refined, 4);
}

TEST(DenseRefinement, CacheKeepsTheMostRecentlyUsed) {
  DenseFrameCache cache(2);
  auto frame = [] { return std::make_shared<const DenseFrame>(); };
  cache.Put(1, frame());
  cache.Put(2, frame());
  EXPECT_NE(cache.Get(1), nullptr);  // 1 is now the most recent
  cache.Put(3, frame());             // evicts 2
  EXPECT_EQ(cache.Get(2), nullptr);
  EXPECT_NE(cache.Get(1), nullptr);
  EXPECT_NE(cache.Get(3), nullptr);
  EXPECT_EQ(cache.size(), 2u);
}

}  // namespace
}  // namespace loci::place::testing
