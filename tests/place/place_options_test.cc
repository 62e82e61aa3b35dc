// The `place` options: defaults, YAML, validation, unknown keys, and that config/server.yaml
// documents the defaults.
#include "server/place/place_options.h"

#include <gtest/gtest.h>

#include "common/config.h"

namespace loci::place {
namespace {

class PlaceOptionsTest : public ::testing::Test {
 protected:
  void TearDown() override { SetStrictConfig(false); }
};

TEST_F(PlaceOptionsTest, DefaultsAreValid) { EXPECT_TRUE(PlaceOptions().Validate().ok()); }

TEST_F(PlaceOptionsTest, ReadsOnlyThePresentKeys) {
  PlaceOptions o;
  ASSERT_TRUE(o.FromYaml(YAML::Load("verify: {ratio: 0.7, min_inliers: 40}\n"
                                    "query: {exclude_recent_keyframes: 25}\n"
                                    "consistency: {min_matches: 4, max_rotation_deg: 2.0}\n"))
                  .ok());
  EXPECT_DOUBLE_EQ(o.verify.ratio, 0.7);
  EXPECT_EQ(o.verify.min_inliers, 40);
  EXPECT_EQ(o.query.exclude_recent_keyframes, 25);
  EXPECT_EQ(o.consistency.min_matches, 4);
  EXPECT_DOUBLE_EQ(o.consistency.max_rotation_deg, 2.0);
  EXPECT_EQ(o.features.max_features, PlaceOptions().features.max_features);  // untouched
}

TEST_F(PlaceOptionsTest, RejectsOutOfRangeValuesNamingThem) {
  for (const char* yaml : {"verify: {ratio: 1.5}", "verify: {min_inliers: 2}",
                           "vocabulary: {branching: 1}", "features: {max_depth_m: 0.05}",
                           "consistency: {min_matches: 0}", "query: {min_score: 1.0}",
                           "query: {older_candidates: -1}", "query: {older_than_keyframes: -5}"}) {
    PlaceOptions o;
    const Status s = o.FromYaml(YAML::Load(yaml));
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << yaml;
  }
  PlaceOptions o;
  const Status s = o.FromYaml(YAML::Load("verify: {ratio: 1.5}"));
  EXPECT_NE(s.message().find("verify.ratio"), std::string::npos) << s;
  EXPECT_FALSE(o.FromYaml(YAML::Load("verify: {ratio: fast}")).ok());  // ill-typed
}

TEST_F(PlaceOptionsTest, UnknownKeysFailWhenStrict) {
  SetStrictConfig(true);
  const Status s = PlaceOptions().FromYaml(YAML::Load("verify:\n  min_inlier: 20\n"));
  ASSERT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("unknown key 'min_inlier' in 'place.verify'"), std::string::npos) << s;
  EXPECT_FALSE(PlaceOptions().FromYaml(YAML::Load("vocab: {}\n")).ok());
}

TEST_F(PlaceOptionsTest, ShippedServerConfigDocumentsTheDefaults) {
  SetStrictConfig(true);
  auto root = LoadYamlFile(SourceDir() + "/config/server.yaml");
  ASSERT_TRUE(root.ok()) << root.status();
  ASSERT_TRUE((*root)["place"]) << "config/server.yaml has no place section";
  PlaceOptions o;
  ASSERT_TRUE(o.FromYaml((*root)["place"]).ok());
  const PlaceOptions d;
  EXPECT_EQ(o.features.max_features, d.features.max_features);
  EXPECT_DOUBLE_EQ(o.features.max_depth_m, d.features.max_depth_m);
  EXPECT_EQ(o.vocabulary.word_max_hamming, d.vocabulary.word_max_hamming);
  EXPECT_EQ(o.vocabulary.max_leaf_words, d.vocabulary.max_leaf_words);
  EXPECT_EQ(o.query.exclude_recent_keyframes, d.query.exclude_recent_keyframes);
  EXPECT_DOUBLE_EQ(o.query.min_score, d.query.min_score);
  EXPECT_EQ(o.query.older_candidates, d.query.older_candidates);
  EXPECT_EQ(o.query.older_than_keyframes, d.query.older_than_keyframes);
  EXPECT_DOUBLE_EQ(o.verify.ratio, d.verify.ratio);
  EXPECT_EQ(o.verify.min_inliers, d.verify.min_inliers);
  EXPECT_DOUBLE_EQ(o.verify.max_rms_m, d.verify.max_rms_m);
  EXPECT_DOUBLE_EQ(o.verify.min_inlier_area, d.verify.min_inlier_area);
  EXPECT_DOUBLE_EQ(o.verify.depth_sigma_m_per_m2, d.verify.depth_sigma_m_per_m2);
  EXPECT_EQ(o.consistency.min_matches, d.consistency.min_matches);
  EXPECT_DOUBLE_EQ(o.consistency.max_translation_m, d.consistency.max_translation_m);
  EXPECT_DOUBLE_EQ(o.consistency.max_rotation_deg, d.consistency.max_rotation_deg);
}

}  // namespace
}  // namespace loci::place
