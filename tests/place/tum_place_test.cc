// Place recognition and verification on the shipped real sample (60 frames of TUM fr1_rpy,
// 2 s of a hand-held camera swinging about 50 deg and back at 50-70 deg/s) and on a synthetic
// scene with exact ground truth.
//
// Ground truth of the sample: groundtruth.txt (motion capture, 100 Hz) gives T_world_cam of
// the colour camera; each frame takes the pose whose stamp is nearest its rgb stamp
// (NearestByTime, at most 10 ms away), and the truth of a pair is
// T_a_b = T_world_a^-1 * T_world_b. At 50-70 deg/s that truth is itself uncertain by degrees:
// the verified transforms fit it best when the mocap stamps are taken 15-20 ms earlier than the
// image stamps (measured, server/place/README.md), and the Kinect's rolling shutter and
// unsynchronised depth add to it. So the sample checks that verification finds the right
// transform to within 10 cm and 7 deg per pair and 4 cm and 3 deg in the median (a wrong place,
// the identity or an inverted transform are off by 10 deg or more on the pairs used); the
// 3 cm / 1 deg accuracy is checked on synthetic frames with exact truth here and on slow-moving
// pairs of the full sequence (tum_full_place_test.cc, slow).
#include <gtest/gtest.h>

#include <algorithm>
#include <numbers>
#include <opencv2/features2d.hpp>
#include <random>

#include "common/config.h"
#include "server/place/binary_descriptor.h"
#include "server/place/geometric_verification.h"
#include "server/place/place_database.h"
#include "synth/renderer.h"
#include "synth/scene.h"
#include "tests/place/place_test_util.h"
#include "tests/place/tum_keyframes.h"

namespace loci::place::testing {
namespace {

constexpr int kMinFramesApart = 30;  // 1 s at 30 Hz
// A query is expected to find a frame when one >= 1 s back is within kRevisitDeg of its view;
// a candidate sees the same place when within kOverlapDeg (the images then still overlap by
// more than half: the field of view is 62 x 49 deg).
constexpr double kRevisitDeg = 15.0;
constexpr double kOverlapDeg = 25.0;

const std::vector<TumKeyframe>& Sample() {
  static const std::vector<TumKeyframe> kfs = [] {
    auto r = LoadTumKeyframes(SourceDir() + "/tests/data/tum_fr1_rpy_sample", 1, 0,
                              FeatureOptions{}, /*keep_images=*/true);
    EXPECT_TRUE(r.ok()) << r.status();
    return r.ok() ? *r : std::vector<TumKeyframe>{};
  }();
  return kfs;
}

bool Within(const TumKeyframe& a, const TumKeyframe& b, double max_deg) {
  const SE3d gt = GroundTruthT_a_b(a, b);
  return Deg(RotationAngleRad(gt)) <= max_deg && gt.translation().norm() <= 0.3;
}

TEST(TumSamplePlaceTest, RetrievesFramesFarApartInTimeThatSeeTheSamePlace) {
  const auto& kfs = Sample();
  ASSERT_EQ(kfs.size(), 60u);
  PlaceOptions o;
  o.query.exclude_recent_keyframes = kMinFramesApart;
  PlaceDatabase db(o.vocabulary, o.query);
  int queries = 0, top1_same = 0;
  for (size_t i = 0; i < kfs.size(); ++i) {
    const BowVector bow = db.Quantise(kfs[i].features.descriptors, true);
    const std::vector<PlaceCandidate> c = db.Query(bow, "fr1");
    bool expected = false;
    for (size_t j = 0; j + kMinFramesApart <= i; ++j)
      expected |= Within(kfs[i], kfs[j], kRevisitDeg);
    if (i < kMinFramesApart) {
      EXPECT_TRUE(c.empty()) << i;  // every earlier frame is in the window
    }
    if (expected) {
      ++queries;
      ASSERT_FALSE(c.empty()) << "frame " << i << " retrieved nothing";
      int same = 0;
      for (const PlaceCandidate& cand : c) {
        EXPECT_LE(cand.keyframe_id + kMinFramesApart, static_cast<int64_t>(i));  // the window
        same += Within(kfs[i], kfs[cand.keyframe_id], kOverlapDeg) ? 1 : 0;
      }
      EXPECT_GT(same, 0) << "frame " << i << ": no candidate sees the same place";
      top1_same += Within(kfs[i], kfs[c[0].keyframe_id], kOverlapDeg) ? 1 : 0;
      // The best candidate is a true match: verification accepts it.
      const Verification v = VerifyPair(kfs[i].features, kfs[c[0].keyframe_id].features, o.verify);
      EXPECT_TRUE(v.accepted) << "frame " << i << " vs " << c[0].keyframe_id << ": " << v.reason;
    }
    ASSERT_TRUE(db.Insert(static_cast<int64_t>(i), "fr1", bow).ok());
  }
  std::cout << "sample: " << queries << " queries with a same-place frame >= 1 s back, top-1 "
            << top1_same << " of them; " << db.words() << " words\n";
  EXPECT_GE(queries, 15);
  EXPECT_GE(top1_same, queries - 1);
}

TEST(TumSamplePlaceTest, VerificationRecoversTheRelativeTransform) {
  const auto& kfs = Sample();
  ASSERT_EQ(kfs.size(), 60u);
  const VerifyOptions o;
  ErrorStats errors;
  double min_area = 1.0;
  for (size_t i = 40; i < kfs.size(); i += 2) {
    for (size_t j = 0; j + kMinFramesApart <= i; ++j) {
      const SE3d gt = GroundTruthT_a_b(kfs[i], kfs[j]);
      const double gt_deg = Deg(RotationAngleRad(gt));
      if (gt_deg < 10.0 || gt_deg > 25.0) continue;
      const Verification v = VerifyPair(kfs[i].features, kfs[j].features, o);
      ASSERT_TRUE(v.accepted) << i << " vs " << j << ": " << v.reason;
      const PoseError e = Error(gt, v.T_a_b);
      EXPECT_LE(e.t_m, 0.10) << i << " vs " << j << " (truth " << gt_deg << " deg)";
      EXPECT_LE(e.r_deg, 7.0) << i << " vs " << j << " (truth " << gt_deg << " deg)";
      min_area = std::min(min_area, v.inlier_area);
      errors.Add(e);
    }
  }
  std::cout << "sample verification vs ground truth at the rgb stamps: " << errors.Summary()
            << "; smallest inlier area " << min_area << "\n";
  EXPECT_GE(errors.size(), 20u);
  EXPECT_LE(errors.MedianT(), 0.04);
  EXPECT_LE(errors.MedianR(), 3.0);
}

// Verification's matcher finds what OpenCV's brute-force matcher finds, on real ORB features.
TEST(TumSamplePlaceTest, TwoNearestRowsAgreeWithOpenCvsBruteForceMatcher) {
  const auto& kfs = Sample();
  ASSERT_EQ(kfs.size(), 60u);
  size_t compared = 0, unique_best = 0;
  for (size_t i = 0; i + 7 < kfs.size(); i += 7) {
    const cv::Mat& q = kfs[i].features.descriptors;
    const cv::Mat& t = kfs[i + 7].features.descriptors;
    std::vector<std::vector<cv::DMatch>> knn;
    cv::BFMatcher(cv::NORM_HAMMING).knnMatch(q, t, knn, 2);
    const std::vector<TwoNearest> ours = TwoNearestRows(q, t);
    ASSERT_EQ(ours.size(), knn.size());
    for (size_t r = 0; r < ours.size(); ++r) {
      ASSERT_EQ(knn[r].size(), 2u);
      EXPECT_EQ(ours[r].best, static_cast<int>(knn[r][0].distance)) << i << ", row " << r;
      EXPECT_EQ(ours[r].second, static_cast<int>(knn[r][1].distance)) << i << ", row " << r;
      if (ours[r].best < ours[r].second) {
        EXPECT_EQ(ours[r].index, knn[r][0].trainIdx) << i << ", row " << r;
        ++unique_best;
      }
      ++compared;
    }
  }
  EXPECT_GE(compared, 4000u);
  EXPECT_GE(unique_best, compared / 2);
  // No train rows: nothing is near.
  EXPECT_EQ(TwoNearestRows(kfs[0].features.descriptors, cv::Mat(0, 32, CV_8UC1))[0].index, -1);
}

TEST(TumSamplePlaceTest, VerifyingAFrameWithItselfGivesTheIdentity) {
  const TumKeyframe& kf = Sample().at(0);
  const Verification v = VerifyPair(kf.features, kf.features, VerifyOptions{});
  ASSERT_TRUE(v.accepted) << v.reason;
  EXPECT_GT(v.inliers, 300);
  EXPECT_LT(Error(SE3d::Identity(), v.T_a_b).t_m, 1e-3);
  EXPECT_LT(Error(SE3d::Identity(), v.T_a_b).r_deg, 0.05);
}

// The sample's first frame with its image and depth cut into blocks and shuffled: most local
// patches (and so descriptors) survive, the geometry only within a block. A 96 px block holds
// 48 consistent matches, refused by min_inlier_area. (A 160 px block, 8% of the image, holds 72
// and is accepted: it is a consistent partial view; the consistency gate, which wants 3
// keyframes to agree, is the guard against such single matches.)
TEST(TumSamplePlaceTest, RejectsAScrambledImageOfTheSamePlace) {
  const TumKeyframe& kf = Sample().at(0);
  cv::Mat bgr, depth_m;
  for (const int block_px : {64, 96}) {
    ShuffleBlocks(kf.bgr, kf.depth_m, block_px, 7, &bgr, &depth_m);
    auto scrambled = ExtractFeatures(bgr, depth_m, PinholeCamera::TumFr1(), FeatureOptions{});
    ASSERT_TRUE(scrambled.ok());
    const Verification v = VerifyPair(kf.features, *scrambled, VerifyOptions{});
    std::cout << "scrambled in " << block_px << " px blocks: " << v.matches << " matches, "
              << v.pnp_inliers << " PnP inliers, " << v.inliers << " 3D inliers: " << v.reason
              << "\n";
    EXPECT_GT(v.matches, 60);  // the descriptors do match ...
    EXPECT_FALSE(v.accepted);  // ... but only block by block
  }
}

TEST(TumSamplePlaceTest, RejectsASyntheticRoomAgainstTheRealRoom) {
  synth::SceneOptions so;
  so.seed = 3;
  so.depth_noise = true;
  auto scene = synth::MakeScene(so);
  ASSERT_TRUE(scene.ok());
  int rejected = 0;
  for (int f = 0; f < 3; ++f) {
    const SyntheticFrame s = RenderSynthetic(*scene, f * 100, FeatureOptions{});
    for (size_t i = 0; i < Sample().size(); i += 20) {
      const Verification v = VerifyPair(Sample()[i].features, s.features, VerifyOptions{});
      EXPECT_FALSE(v.accepted) << "synthetic frame " << f * 100 << " vs real " << i;
      rejected += v.accepted ? 0 : 1;
    }
  }
  EXPECT_EQ(rejected, 9);
}

// Exact truth: frames of a synthetic room with Kinect-like depth noise, 2 s or more apart.
TEST(SyntheticPlaceTest, VerificationIsWithinThreeCentimetresAndOneDegreeOfExactTruth) {
  const std::vector<SyntheticFrame> frames = NoisyRoomFrames();
  ASSERT_EQ(frames.size(), 20u);
  ErrorStats errors;
  int tried = 0;
  for (size_t i = 0; i < frames.size(); ++i) {
    for (size_t j = 0; j + 4 <= i; ++j) {
      const SE3d gt = frames[i].T_world_cam.inverse() * frames[j].T_world_cam;
      if (Deg(RotationAngleRad(gt)) > 25.0) continue;
      ++tried;
      const Verification v = VerifyPair(frames[i].features, frames[j].features, VerifyOptions{});
      if (v.accepted) errors.Add(Error(gt, v.T_a_b));
    }
  }
  std::cout << "synthetic: " << errors.size() << " of " << tried << " pairs verified; "
            << errors.Summary() << "\n";
  EXPECT_GE(errors.size(), static_cast<size_t>(0.9 * tried));
  EXPECT_LE(errors.MedianT(), 0.03);
  EXPECT_LE(errors.MedianR(), 1.0);
  EXPECT_LE(errors.QuantileR(0.9), 1.0);
}

}  // namespace
}  // namespace loci::place::testing
