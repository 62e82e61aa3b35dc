#include "common/detections_io.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

namespace loci {
namespace {

TEST(DetectionsIo, JsonlRoundTripWithMask) {
  FrameDetections f;
  f.t_ns = 1305031229528748000LL;
  Detection2D d;
  d.class_id = 41;
  d.class_name = "cup";
  d.score = 0.75f;
  d.box_px = cv::Rect2f(10.5f, 20.f, 30.f, 40.f);
  d.track_id = 7;
  d.mask = cv::Mat::zeros(40, 31, CV_8UC1);
  cv::circle(d.mask, {15, 20}, 10, cv::Scalar(255), -1);
  f.detections.push_back(d);
  Detection2D e = d;
  e.mask.release();
  e.class_name = "book";
  f.detections.push_back(e);

  const std::string path = ::testing::TempDir() + "/det.jsonl";
  ASSERT_TRUE(WriteDetectionsJsonl(path, {f}).ok());
  auto back = ReadDetectionsJsonl(path);
  ASSERT_TRUE(back.ok()) << back.status();
  ASSERT_EQ(back->size(), 1u);
  const FrameDetections& g = (*back)[0];
  EXPECT_EQ(g.t_ns, f.t_ns);
  ASSERT_EQ(g.detections.size(), 2u);
  EXPECT_EQ(g.detections[0].class_name, "cup");
  EXPECT_EQ(g.detections[0].track_id, 7);
  EXPECT_FLOAT_EQ(g.detections[0].box_px.x, 10.5f);
  ASSERT_FALSE(g.detections[0].mask.empty());
  EXPECT_EQ(cv::norm(g.detections[0].mask, d.mask, cv::NORM_INF), 0.0);
  EXPECT_TRUE(g.detections[1].mask.empty());
  EXPECT_EQ(FindDetections(*back, f.t_ns + 5'000'000), &(*back)[0]);
  EXPECT_EQ(FindDetections(*back, f.t_ns + 50'000'000), nullptr);
}

TEST(DetectionsIo, BadLinesNameTheLine) {
  EXPECT_FALSE(DetectionsFromJsonLine("{not json").ok());
  EXPECT_FALSE(DetectionsFromJsonLine(R"({"t_ns": 1, "detections": [{"class_name": "cup", "box": [1, 2, 3]}]})").ok());
  EXPECT_FALSE(DetectionsFromJsonLine(R"({"t_ns": 1, "detections": [{"class_name": "cup", "box": [1, 2, 0, 3]}]})").ok());
  EXPECT_EQ(MaskRect(cv::Rect2f(-2.5f, 1.2f, 10.f, 5.f), 6, 100), cv::Rect(0, 1, 6, 6));
}

}  // namespace
}  // namespace loci
