// The feature cache in front of a store (features out of memory), on real features of
// the shipped TUM sample.
#include <gtest/gtest.h>

#include "common/config.h"
#include "server/place/feature_cache.h"
#include "tests/place/tum_keyframes.h"

namespace loci::place::testing {
namespace {

std::vector<KeyframeFeatures> SampleFeatures(int n) {
  auto kfs = LoadTumKeyframes(SourceDir() + "/tests/data/tum_fr1_rpy_sample", 10, n,
                              FeatureOptions{});
  EXPECT_TRUE(kfs.ok()) << kfs.status();
  std::vector<KeyframeFeatures> out;
  if (kfs.ok()) {
    for (auto& k : *kfs) out.push_back(k.features);
  }
  return out;
}

bool SameDescriptors(const KeyframeFeatures& a, const KeyframeFeatures& b) {
  return a.size() == b.size() && a.descriptors.rows == b.descriptors.rows &&
         cv::countNonZero(a.descriptors != b.descriptors) == 0;
}

class FailingStore final : public FeatureStore {
 public:
  Status Put(int64_t, const KeyframeFeatures&) override {
    return absl::UnavailableError("disk full");
  }
  StatusOr<std::optional<KeyframeFeatures>> Get(int64_t) override {
    return std::optional<KeyframeFeatures>();
  }
};

TEST(FeatureCacheTest, KeepsTheMostRecentAndReadsTheRestBackFromTheStore) {
  const std::vector<KeyframeFeatures> f = SampleFeatures(3);
  ASSERT_EQ(f.size(), 3u);
  MemoryFeatureStore store;
  FeatureCache cache(&store, 2);
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(cache.Put(i + 1, f[i]).ok());
  EXPECT_EQ(cache.Stats().cached, 2u);
  // 3 and 2 are cached; 1 was evicted and comes back from the store.
  auto third = cache.Get(3);
  ASSERT_TRUE(third.ok());
  EXPECT_TRUE(SameDescriptors(**third, f[2]));
  EXPECT_EQ(cache.Stats().hits, 1u);
  EXPECT_EQ(cache.Stats().misses, 0u);
  auto first = cache.Get(1);
  ASSERT_TRUE(first.ok()) << first.status();
  EXPECT_TRUE(SameDescriptors(**first, f[0]));
  EXPECT_EQ(cache.Stats().misses, 1u);
  // Reading 1 evicted 2 (3 was used more recently); features handed out stay valid.
  auto second = cache.Get(2);
  ASSERT_TRUE(second.ok());
  EXPECT_EQ(cache.Stats().misses, 2u);
  EXPECT_TRUE(SameDescriptors(**first, f[0]));
  EXPECT_EQ(cache.Stats().cached, 2u);
}

TEST(FeatureCacheTest, UnknownKeyframeIsNotFound) {
  MemoryFeatureStore store;
  FeatureCache cache(&store, 4);
  auto missing = cache.Get(42);
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.status().code(), absl::StatusCode::kNotFound);
}

TEST(FeatureCacheTest, AFailedStoreIsReportedAndTheFeaturesStayCached) {
  const std::vector<KeyframeFeatures> f = SampleFeatures(1);
  ASSERT_EQ(f.size(), 1u);
  FailingStore store;
  FeatureCache cache(&store, 2);
  const Status put = cache.Put(7, f[0]);
  EXPECT_EQ(put.code(), absl::StatusCode::kUnavailable);
  auto back = cache.Get(7);
  ASSERT_TRUE(back.ok());
  EXPECT_TRUE(SameDescriptors(**back, f[0]));
}

}  // namespace
}  // namespace loci::place::testing
