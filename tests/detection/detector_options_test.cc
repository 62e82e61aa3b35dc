#include "detection/detector_options.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "detection/detection_config.h"

namespace loci::detection {
namespace {

std::string TempPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          (std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" + name))
      .string();
}

TEST(DetectionConfig, ShippedConfigLoads) {
  auto c = LoadDetectionConfig(DefaultDetectionConfigPath());
  ASSERT_TRUE(c.ok()) << c.status();
  EXPECT_EQ(c->detector.type, "yolox");
  EXPECT_TRUE(std::filesystem::exists(c->detector.model_path)) << c->detector.model_path;
  // Class filter = config/classes.yaml `mapped` list.
  EXPECT_TRUE(c->detector.Keeps("cup"));
  EXPECT_TRUE(c->detector.Keeps("teddy bear"));
  EXPECT_TRUE(c->detector.Keeps("person"));
  EXPECT_FALSE(c->detector.Keeps("banana"));
  EXPECT_FLOAT_EQ(c->detector.ThresholdFor("person"), 0.4f);
  EXPECT_FLOAT_EQ(c->detector.ThresholdFor("keyboard"), c->detector.score_threshold);
  EXPECT_EQ(c->tracker.n_init, 2);
  EXPECT_FLOAT_EQ(c->mask.depth_scale, 5000.f);
}

TEST(DetectionConfig, BadValuesAreRejected) {
  EXPECT_FALSE(DetectorOptions::FromYaml(YAML::Load("{type: ssd}")).ok());
  EXPECT_FALSE(DetectorOptions::FromYaml(YAML::Load("{input_size_px: 100}")).ok());
  EXPECT_FALSE(DetectorOptions::FromYaml(YAML::Load("{score_threshold: 2}")).ok());
  EXPECT_FALSE(DetectorOptions::FromYaml(YAML::Load("{class_score_thresholds: {cup: x}}")).ok());
  EXPECT_FALSE(DetectorOptions::FromYaml(YAML::Load("{classes: cup}")).ok());
  auto o = DetectorOptions::FromYaml(YAML::Load("{classes: [cup, book], model: m.onnx}"), "/x");
  ASSERT_TRUE(o.ok());
  EXPECT_EQ(o->model_path, "/x/m.onnx");
  EXPECT_TRUE(o->Keeps("book"));
  EXPECT_FALSE(o->Keeps("tv"));
}

TEST(MakeDetector, MissingModelIsNotFound) {
  for (const char* type : {"yolox", "nanodet"}) {
    DetectorOptions o;
    o.type = type;
    o.model_path = "/nonexistent/model.onnx";
    o.class_names_path = std::string(LOCI_SOURCE_DIR) + "/models/yolox_nano/coco80.names";
    auto d = MakeDetector(o);
    ASSERT_FALSE(d.ok());
    EXPECT_EQ(d.status().code(), absl::StatusCode::kNotFound) << d.status();
    EXPECT_NE(d.status().message().find("/nonexistent/model.onnx"), std::string::npos);
  }
}

TEST(MakeDetector, CorruptModelIsAnErrorNotACrash) {
  const std::string bad = TempPath("corrupt.onnx");
  {
    std::ofstream out(bad, std::ios::binary);
    out << "this is not a protobuf \x01\x02\x03 model";
  }
  // Also a truncated copy of the real model.
  const std::string truncated = TempPath("truncated.onnx");
  {
    std::ifstream in(std::string(LOCI_SOURCE_DIR) + "/models/yolox_nano/yolox_nano.onnx",
                     std::ios::binary);
    std::string head(200000, '\0');
    in.read(head.data(), head.size());
    std::ofstream out(truncated, std::ios::binary);
    out.write(head.data(), in.gcount());
  }
  for (const std::string& path : {bad, truncated}) {
    for (const char* type : {"yolox", "nanodet"}) {
      DetectorOptions o;
      o.type = type;
      o.model_path = path;
      o.class_names_path = std::string(LOCI_SOURCE_DIR) + "/models/yolox_nano/coco80.names";
      auto d = MakeDetector(o);
      EXPECT_FALSE(d.ok()) << type << " " << path;
    }
  }
  std::filesystem::remove(bad);
  std::filesystem::remove(truncated);
}

TEST(MakeDetector, FileDetectorLooksUpByStampAndFilters) {
  const std::string path = TempPath("dets.jsonl");
  FrameDetections f1{1'000'000'000, {}}, f2{2'000'000'000, {}};
  Detection2D cup;
  cup.class_id = 41;
  cup.class_name = "cup";
  cup.score = 0.9f;
  cup.box_px = {10, 10, 20, 30};
  Detection2D banana = cup;
  banana.class_id = 46;
  banana.class_name = "banana";
  Detection2D weak = cup;
  weak.score = 0.1f;
  f1.detections = {cup, banana, weak};
  ASSERT_TRUE(WriteDetectionsJsonl(path, {f2, f1}).ok());
  DetectorOptions o;
  o.type = "file";
  o.detections_path = path;
  o.classes = {"cup"};
  auto d = MakeDetector(o);
  ASSERT_TRUE(d.ok()) << d.status();
  EXPECT_EQ((*d)->Name(), "file:" + path);
  auto r = (*d)->Detect(cv::Mat(), 1'000'000'000 + 5'000'000);
  ASSERT_TRUE(r.ok());
  ASSERT_EQ(r->size(), 1u);
  EXPECT_EQ((*r)[0].class_name, "cup");
  EXPECT_EQ((*r)[0].box_px, cv::Rect2f(10, 10, 20, 30));
  auto none = (*d)->Detect(cv::Mat(), 1'500'000'000);
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
  std::filesystem::remove(path);

  o.detections_path = "/nonexistent/dets.jsonl";
  EXPECT_FALSE(MakeDetector(o).ok());
}

}  // namespace
}  // namespace loci::detection
