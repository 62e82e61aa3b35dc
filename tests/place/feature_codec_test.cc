// Stored features: a real keyframe's features survive encoding exactly; corrupt records are
// refused with a status.
#include "server/place/feature_codec.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "common/config.h"
#include "tests/place/tum_keyframes.h"

namespace loci::place {
namespace {

KeyframeFeatures RealFeatures() {
  auto kfs = testing::LoadTumKeyframes(SourceDir() + "/tests/data/tum_fr1_rpy_sample", 1, 1,
                                       FeatureOptions{});
  EXPECT_TRUE(kfs.ok()) << kfs.status();
  return kfs.ok() ? (*kfs)[0].features : KeyframeFeatures{};
}

TEST(FeatureCodecTest, RealKeyframeRoundTripsExactly) {
  const KeyframeFeatures f = RealFeatures();
  ASSERT_GT(f.size(), 500u);
  ASSERT_GT(f.CountWithDepth(), f.size() / 2);
  auto bytes = EncodeFeatures(f);
  ASSERT_TRUE(bytes.ok()) << bytes.status();
  EXPECT_EQ(bytes->size(), kFeatureHeaderBytes + kFeatureRecordBytes * f.size());
  auto g = DecodeFeatures(*bytes);
  ASSERT_TRUE(g.ok()) << g.status();
  ASSERT_EQ(g->size(), f.size());
  EXPECT_EQ(g->camera.fx, f.camera.fx);
  EXPECT_EQ(g->camera.cy, f.camera.cy);
  EXPECT_EQ(g->camera.width_px, f.camera.width_px);
  EXPECT_EQ(g->level_scale, f.level_scale);
  EXPECT_EQ(cv::norm(g->descriptors, f.descriptors, cv::NORM_HAMMING), 0);
  for (size_t i = 0; i < f.size(); ++i) {
    ASSERT_EQ(g->uv_px[i], f.uv_px[i]) << i;
    ASSERT_EQ(g->octave[i], f.octave[i]) << i;
    ASSERT_EQ(g->p_kf_m[i], f.p_kf_m[i]) << i;
  }
}

TEST(FeatureCodecTest, EmptyFeaturesRoundTrip) {
  KeyframeFeatures f;
  f.camera = PinholeCamera::TumFr1();
  f.descriptors = cv::Mat(0, kDescriptorBytes, CV_8UC1);
  auto bytes = EncodeFeatures(f);
  ASSERT_TRUE(bytes.ok());
  EXPECT_EQ(bytes->size(), kFeatureHeaderBytes);
  auto g = DecodeFeatures(*bytes);
  ASSERT_TRUE(g.ok()) << g.status();
  EXPECT_EQ(g->size(), 0u);
}

TEST(FeatureCodecTest, CorruptRecordsAreRefused) {
  const KeyframeFeatures f = RealFeatures();
  auto bytes = EncodeFeatures(f);
  ASSERT_TRUE(bytes.ok());
  const std::string good = *bytes;
  EXPECT_FALSE(DecodeFeatures(good.substr(0, good.size() - 1)).ok());  // truncated
  EXPECT_FALSE(DecodeFeatures(good + "x").ok());                       // trailing byte
  EXPECT_FALSE(DecodeFeatures("").ok());
  std::string magic = good;
  magic[0] = 'X';
  EXPECT_FALSE(DecodeFeatures(magic).ok());
  std::string count = good;
  const uint32_t huge = 0xFFFFFFFFu;
  std::memcpy(count.data() + 4, &huge, 4);
  EXPECT_FALSE(DecodeFeatures(count).ok());
  std::string nan = good;  // z of the first point
  const float bad = std::nanf("");
  std::memcpy(nan.data() + kFeatureHeaderBytes + kFeatureRecordBytes - 4, &bad, 4);
  const Status s = DecodeFeatures(nan).status();
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  std::string camera = good;  // fx = 0
  const double zero = 0;
  std::memcpy(camera.data() + 8, &zero, 8);
  EXPECT_FALSE(DecodeFeatures(camera).ok());
}

TEST(FeatureCodecTest, InconsistentFeaturesAreNotEncoded) {
  KeyframeFeatures f = RealFeatures();
  f.octave.pop_back();
  EXPECT_FALSE(EncodeFeatures(f).ok());
}

}  // namespace
}  // namespace loci::place
