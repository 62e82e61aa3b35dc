// RobotAligner with its features and images out of memory (issues 14, 15), and placing a robot
// by where the matched keyframes are mapped after a loop closure: on the shipped real
// TUM sample, robot A (frames 0-39, aligned: it defines the map) and robot B (frames 20-59, its
// own odometry from the identity at its first frame, unaligned). B is aligned the same way, to
// the same transform, whether every keyframe's features and reduced images stay in memory or
// only two do and the rest are read back from the store; and from its newest keyframes queried
// ahead of a backlog.
#include <gtest/gtest.h>

#include <memory>

#include "common/config.h"
#include "server/align/robot_aligner.h"
#include "tests/place/tum_keyframes.h"

namespace loci::server {
namespace {

using place::testing::TumKeyframe;

const std::vector<TumKeyframe>& Sample() {
  static const std::vector<TumKeyframe> kfs = [] {
    auto r = place::testing::LoadTumKeyframes(SourceDir() + "/tests/data/tum_fr1_rpy_sample", 1,
                                              0, place::FeatureOptions{}, /*keep_images=*/true);
    EXPECT_TRUE(r.ok()) << r.status();
    return r.ok() ? *r : std::vector<TumKeyframe>{};
  }();
  return kfs;
}

// Sample frame i as session `session` sends it: id 1000 * session + i, its odometry from the
// identity at frame `first`.
AlignKeyframe SampleKeyframe(int session, int i, int first) {
  const auto& kfs = Sample();
  return AlignKeyframe{1000 * session + i, session, kfs[i].t_ns,
                       kfs[first].T_world_cam.inverse() * kfs[i].T_world_cam, std::nullopt};
}

// These tests' aligner: no loop closure, no refinement (the first consensus is the placement);
// session 1 (A) is aligned, session 2 (B) is not.
std::unique_ptr<RobotAligner> AlignerForAAndB(const place::PlaceOptions& place,
                                              place::FeatureStore* store,
                                              place::KeyframeImageSource* images) {
  AlignOptions options;
  options.loops.enabled = false;
  options.refine_max_matches = 0;
  auto aligner = std::make_unique<RobotAligner>(place, options, store, images);
  aligner->AddSession(1, SE3d::Identity());
  aligner->AddSession(2, std::nullopt);
  return aligner;
}

struct AlignRun {
  std::optional<SessionAlignment> alignment;
  AlignStats stats;
};

// The sample's images by keyframe id (1000 * session + frame), as the database gives them back.
class SampleImages final : public place::KeyframeImageSource {
 public:
  StatusOr<std::optional<place::KeyframeImages>> Read(int64_t keyframe_id) override {
    ++reads;
    const size_t i = static_cast<size_t>(keyframe_id % 1000);
    if (i >= Sample().size()) return std::optional<place::KeyframeImages>();
    const TumKeyframe& kf = Sample()[i];
    return std::optional<place::KeyframeImages>(
        place::KeyframeImages{kf.bgr, kf.depth_m, kf.features.camera});
  }
  int reads = 0;
};

// How robot A's odometry errs: from its 10th frame on, every keyframe is put T_slip off (a
// wheel or tracking slip); with `corrected`, A's loop closure has put them back where the ground
// truth has them, and the aligner is told (SetMappedPoses).
struct ASlip {
  SE3d T_slip = SE3d::Identity();
  bool corrected = false;
};

// A then B through one aligner whose features live in `store` (null: its own memory) and
// whose reduced images are read back from `images` (null: none) beyond `dense_cache` of them.
AlignRun AlignBToA(int cache_keyframes, place::FeatureStore* store, int dense_cache = 256,
                   place::KeyframeImageSource* images = nullptr, const ASlip& slip = {}) {
  const auto& kfs = Sample();
  place::PlaceOptions place;
  place.features.cache_keyframes = cache_keyframes;
  place.dense.cache_keyframes = dense_cache;
  const std::unique_ptr<RobotAligner> owned = AlignerForAAndB(place, store, images);
  RobotAligner& aligner = *owned;
  const PinholeCamera camera = kfs.front().features.camera;
  AlignRun run;
  auto add = [&](int session, int i, int first) {
    AlignKeyframe kf = SampleKeyframe(session, i, first);
    if (session == 1 && i >= 10) {
      if (slip.corrected) aligner.SetMappedPoses(kSharedGraph, {{1000 + i, kf.T_odom_kf}});
      kf.T_odom_kf = slip.T_slip * kf.T_odom_kf;
    }
    auto out = aligner.AddKeyframe(kf, kfs[i].bgr, kfs[i].depth_m, camera);
    ASSERT_TRUE(out.ok()) << out.status();
    if (out->alignment && !run.alignment) run.alignment = out->alignment;
  };
  for (int i = 0; i < 40; ++i) add(1, i, 0);
  for (int i = 20; i < 60; ++i) add(2, i, 20);
  run.stats = aligner.Stats();
  return run;
}

TEST(RobotAlignerTest, FeaturesReadBackFromTheStoreAlignLikeFeaturesInMemory) {
  ASSERT_EQ(Sample().size(), 60u);
  const AlignRun memory = AlignBToA(256, nullptr);
  place::MemoryFeatureStore store;
  const AlignRun stored = AlignBToA(2, &store);
  ASSERT_TRUE(memory.alignment.has_value()) << "B not aligned with every feature in memory";
  ASSERT_TRUE(stored.alignment.has_value()) << "B not aligned with two keyframes cached";
  EXPECT_EQ(memory.stats.features_read, 0u);
  EXPECT_GT(stored.stats.features_read, 0u);
  EXPECT_EQ(stored.stats.features_missing, 0u);
  EXPECT_EQ(stored.alignment->keyframe_id, memory.alignment->keyframe_id);
  EXPECT_TRUE(stored.alignment->T_base_odom.isApprox(memory.alignment->T_base_odom, 1e-12));
  // And it is where the ground truth puts B's start (the sample's truth is good to a few cm).
  const SE3d T_a_b = place::testing::GroundTruthT_a_b(Sample()[0], Sample()[20]);
  EXPECT_LT((stored.alignment->T_base_odom.translation() - T_a_b.translation()).norm(), 0.05);
}

// Dense refinement of a match to a keyframe whose reduced images left the cache: they are read
// back and the refinement is the same as with every keyframe in memory; without a source the
// match keeps its sparse estimate and is counted as without images.
TEST(RobotAlignerTest, ImagesReadBackFromTheStoreRefineLikeImagesInMemory) {
  ASSERT_EQ(Sample().size(), 60u);
  const AlignRun memory = AlignBToA(256, nullptr);
  SampleImages images;
  const AlignRun stored = AlignBToA(256, nullptr, /*dense_cache=*/2, &images);
  const AlignRun none = AlignBToA(256, nullptr, /*dense_cache=*/2, nullptr);
  ASSERT_TRUE(memory.alignment.has_value());
  ASSERT_TRUE(stored.alignment.has_value());
  EXPECT_GT(memory.stats.dense_refined, 0u);
  EXPECT_EQ(memory.stats.dense_frames_read, 0u);
  EXPECT_EQ(memory.stats.dense_without_images, 0u);
  EXPECT_GT(stored.stats.dense_frames_read, 0u);
  EXPECT_EQ(stored.stats.dense_frames_read, static_cast<uint64_t>(images.reads));
  EXPECT_EQ(stored.stats.dense_without_images, 0u);
  EXPECT_EQ(stored.stats.dense_refined, memory.stats.dense_refined);
  EXPECT_EQ(stored.stats.dense_refused, memory.stats.dense_refused);
  EXPECT_EQ(stored.alignment->keyframe_id, memory.alignment->keyframe_id);
  EXPECT_TRUE(stored.alignment->T_base_odom.isApprox(memory.alignment->T_base_odom, 1e-12));
  EXPECT_GT(none.stats.dense_without_images, 0u);
  EXPECT_EQ(none.stats.dense_frames_read, 0u);
  EXPECT_LT(none.stats.dense_refined, memory.stats.dense_refined);
}

// A slipped (0.15 m and 3 deg at its 10th frame) and its loop closure corrected it. B matches
// A's corrected keyframes, so B must be placed by where they are mapped, not by A's odometry
// times its placement: that would carry A's slip into B's placement.
TEST(RobotAlignerTest, ARobotIsAlignedToWhereTheMatchedKeyframesAreMappedNow) {
  ASSERT_EQ(Sample().size(), 60u);
  const SE3d T_a_b = place::testing::GroundTruthT_a_b(Sample()[0], Sample()[20]);
  SE3d T_slip = SE3d::Identity();
  T_slip.linear() = Eigen::AngleAxisd(3.0 * M_PI / 180.0, Vec3d::UnitY()).toRotationMatrix();
  T_slip.translation() = Vec3d(0.15, 0, 0);
  const AlignRun odometry = AlignBToA(256, nullptr, 256, nullptr, {T_slip, false});
  const AlignRun corrected = AlignBToA(256, nullptr, 256, nullptr, {T_slip, true});
  ASSERT_TRUE(odometry.alignment.has_value());
  ASSERT_TRUE(corrected.alignment.has_value());
  const double odometry_err_m =
      (odometry.alignment->T_base_odom.translation() - T_a_b.translation()).norm();
  const double corrected_err_m =
      (corrected.alignment->T_base_odom.translation() - T_a_b.translation()).norm();
  std::printf("B's start vs the truth: %.3f m aligned by A's odometry, %.3f m by A's mapped "
              "poses\n", odometry_err_m, corrected_err_m);
  EXPECT_GT(odometry_err_m, 0.10);
  EXPECT_LT(corrected_err_m, 0.05);
}

// A robot that streamed a backlog: B's keyframes 20-49 still wait to be indexed when its newest
// ones are queried ahead of them. B is aligned from those alone, nothing is indexed until
// AddKeyframe works through the backlog, and then B is not aligned a second time.
TEST(RobotAlignerTest, NewestKeyframesQueriedAheadOfABacklogAlignTheRobot) {
  const auto& kfs = Sample();
  ASSERT_EQ(kfs.size(), 60u);
  const std::unique_ptr<RobotAligner> owned = AlignerForAAndB({}, nullptr, nullptr);
  RobotAligner& aligner = *owned;
  const PinholeCamera camera = kfs.front().features.camera;
  for (int i = 0; i < 40; ++i) {
    const auto out = aligner.AddKeyframe(SampleKeyframe(1, i, 0), kfs[i].bgr, kfs[i].depth_m,
                                         camera);
    ASSERT_TRUE(out.ok()) << out.status();
  }
  // Neither an undeclared session nor an aligned one is queried.
  AlignKeyframe stray = SampleKeyframe(2, 50, 20);
  stray.session_row = 7;
  auto none = aligner.QueryAhead(stray, kfs[50].bgr, kfs[50].depth_m, camera);
  ASSERT_TRUE(none.ok()) << none.status();
  EXPECT_FALSE(none->alignment.has_value());
  EXPECT_TRUE(aligner.QueryAhead(SampleKeyframe(1, 45, 0), kfs[45].bgr, kfs[45].depth_m, camera)
                  ->matches.empty());

  std::optional<SessionAlignment> ahead;
  int queried = 0;
  for (int i = 50; i < 60 && !ahead; ++i, ++queried) {
    auto out = aligner.QueryAhead(SampleKeyframe(2, i, 20), kfs[i].bgr, kfs[i].depth_m, camera);
    ASSERT_TRUE(out.ok()) << out.status();
    ahead = out->alignment;
  }
  ASSERT_TRUE(ahead.has_value()) << "B not aligned by its newest 10 keyframes";
  EXPECT_LE(queried, 5);
  AlignStats stats = aligner.Stats();
  EXPECT_EQ(stats.keyframes, 40u);  // nothing indexed ahead
  EXPECT_EQ(stats.queries_ahead, static_cast<uint64_t>(queried));
  EXPECT_EQ(stats.merges_ahead, 1u);
  EXPECT_TRUE(aligner.Alignment(2).has_value());
  const SE3d T_a_b = place::testing::GroundTruthT_a_b(kfs[0], kfs[20]);
  EXPECT_LT((ahead->T_base_odom.translation() - T_a_b.translation()).norm(), 0.05);
  EXPECT_FALSE(aligner.Delay(2).has_value()) << "known once the aligning keyframe comes in order";

  for (int i = 20; i < 60; ++i) {
    auto out = aligner.AddKeyframe(SampleKeyframe(2, i, 20), kfs[i].bgr, kfs[i].depth_m, camera);
    ASSERT_TRUE(out.ok()) << out.status();
    EXPECT_FALSE(out->alignment.has_value()) << "B aligned again at its keyframe " << i;
  }
  stats = aligner.Stats();
  EXPECT_EQ(stats.keyframes, 80u);
  ASSERT_TRUE(aligner.Delay(2).has_value());
  EXPECT_EQ(aligner.Delay(2)->keyframes, ahead->keyframe_id - 2020 + 1);
  EXPECT_EQ(stats.merges_accepted, 1u);
  // A keyframe indexed since is not queried ahead again.
  EXPECT_TRUE(aligner.QueryAhead(SampleKeyframe(2, 59, 20), kfs[59].bgr, kfs[59].depth_m, camera)
                  ->matches.empty());
}

}  // namespace
}  // namespace loci::server
