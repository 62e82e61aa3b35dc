// objects.json reading: the synth layout (numeric ids) and hand-made ground truth (string ids,
// `on` by name, confidence, visible_part_centroid_m), and clear errors.
#include "common/objects_json.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

namespace loci {
namespace {

std::string WriteTemp(const std::string& name, const std::string& text) {
  const std::string path = (std::filesystem::temp_directory_path() / name).string();
  std::ofstream(path) << text;
  return path;
}

TEST(ObjectsJson, ReadsHandMadeGroundTruth) {
  const std::string path = WriteTemp("loci_objects_gt_test.json", R"({
    "objects": [
      {"id": "desk", "class_name": "dining table", "centroid_m": [0.6, 0.7, 0.4],
       "extent_m": [0.8, 1.5, 0.8], "on": null, "confidence": "high",
       "visible_part_centroid_m": [0.6, 0.7, 0.75]},
      {"id": "mug", "class_name": "cup", "centroid_m": [0.55, 0.68, 0.84],
       "extent_m": [0.1, 0.1, 0.11], "on": "desk", "confidence": "medium"}
    ]})");
  auto scene = ReadObjectsJson(path);
  ASSERT_TRUE(scene.ok()) << scene.status();
  ASSERT_EQ(scene->objects.size(), 2u);
  const GroundTruthObject& desk = scene->objects[0];
  const GroundTruthObject& mug = scene->objects[1];
  EXPECT_EQ(desk.name, "desk");
  EXPECT_EQ(desk.id, 1);
  EXPECT_EQ(desk.confidence, "high");
  ASSERT_TRUE(desk.visible_part_centroid_m.has_value());
  EXPECT_NEAR(desk.visible_part_centroid_m->z(), 0.75, 1e-12);
  EXPECT_EQ(mug.on_id, desk.id);
  EXPECT_EQ(mug.confidence, "medium");
  EXPECT_FALSE(mug.visible_part_centroid_m.has_value());
}

TEST(ObjectsJson, UnknownSupportAndBadConfidenceAreErrors) {
  auto a = ReadObjectsJson(WriteTemp("loci_objects_gt_bad1.json", R"({"objects": [
      {"id": "mug", "class_name": "cup", "centroid_m": [0, 0, 0], "extent_m": [0.1, 0.1, 0.1],
       "on": "nowhere"}]})"));
  ASSERT_FALSE(a.ok());
  EXPECT_NE(a.status().message().find("nowhere"), std::string::npos);
  auto b = ReadObjectsJson(WriteTemp("loci_objects_gt_bad2.json", R"({"objects": [
      {"id": 1, "class_name": "cup", "centroid_m": [0, 0, 0], "extent_m": [0.1, 0.1, 0.1],
       "confidence": "sure"}]})"));
  ASSERT_FALSE(b.ok());
  EXPECT_NE(b.status().message().find("confidence"), std::string::npos);
}

}  // namespace
}  // namespace loci
