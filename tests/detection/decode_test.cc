// Decode and NMS on hand-made output tensors.
#include "common/detections_io.h"
#include "detection/decode.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>

namespace loci::detection {
namespace {

constexpr int kYoloxRows = 52 * 52 + 26 * 26 + 13 * 13;  // 416 input

// Row of stride `stride` cell (gx, gy) in a YOLOX output for a 416 input.
int YoloxRow(int stride, int gx, int gy) {
  int row = 0;
  for (int s : {8, 16, 32}) {
    const int g = 416 / s;
    if (s == stride) return row + gy * g + gx;
    row += g * g;
  }
  return -1;
}

cv::Mat EmptyYolox(int num_classes = 80) {
  const int sizes[] = {1, kYoloxRows, 5 + num_classes};
  return cv::Mat(3, sizes, CV_32F, cv::Scalar(0.f));
}

void SetYolox(cv::Mat* out, int row, float tx, float ty, float tw, float th, float obj, int cls,
              float cls_score) {
  float* p = out->ptr<float>(0) + static_cast<size_t>(row) * out->size[2];
  p[0] = tx;
  p[1] = ty;
  p[2] = tw;
  p[3] = th;
  p[4] = obj;
  p[5 + cls] = cls_score;
}

TEST(DecodeYolox, KnownCellGivesKnownBoxInOriginalImage) {
  // A 640x480 image letterboxed to 416: r = 0.65, padding bottom only.
  cv::Mat image(480, 640, CV_8UC3, cv::Scalar(10, 20, 30));
  Letterbox lb;
  cv::Mat input = LetterboxTopLeft(image, 416, &lb);
  ASSERT_EQ(input.size(), cv::Size(416, 416));
  EXPECT_FLOAT_EQ(lb.scale, 0.65f);
  EXPECT_EQ(input.at<cv::Vec3b>(0, 0), cv::Vec3b(10, 20, 30));       // image at top-left
  EXPECT_EQ(input.at<cv::Vec3b>(415, 0), cv::Vec3b(114, 114, 114));  // 114 padding below

  cv::Mat out = EmptyYolox();
  // Stride 16 cell (10, 7): centre ((0.5 + 10) * 16, (0.25 + 7) * 16) = (168, 116) in letterbox
  // px, size exp(1) * 16 x exp(0.5) * 16.
  SetYolox(&out, YoloxRow(16, 10, 7), 0.5f, 0.25f, 1.f, 0.5f, 0.9f, 62, 0.8f);
  auto c = DecodeYolox(out, 416, lb, 0.3f);
  ASSERT_TRUE(c.ok()) << c.status();
  ASSERT_EQ(c->size(), 1u);
  const float w = std::exp(1.f) * 16, h = std::exp(0.5f) * 16;
  EXPECT_EQ((*c)[0].class_id, 62);
  EXPECT_NEAR((*c)[0].score, 0.72f, 1e-6);
  EXPECT_NEAR((*c)[0].box_px.x, (168 - w / 2) / 0.65f, 1e-3);
  EXPECT_NEAR((*c)[0].box_px.y, (116 - h / 2) / 0.65f, 1e-3);
  EXPECT_NEAR((*c)[0].box_px.width, w / 0.65f, 1e-3);
  EXPECT_NEAR((*c)[0].box_px.height, h / 0.65f, 1e-3);
}

TEST(DecodeYolox, EachStrideUsesItsOwnGridAndScore) {
  Letterbox lb;  // identity
  cv::Mat out = EmptyYolox();
  SetYolox(&out, YoloxRow(8, 51, 0), 0.f, 0.f, 0.f, 0.f, 0.9f, 0, 0.9f);   // last stride-8 col
  SetYolox(&out, YoloxRow(32, 0, 12), 0.f, 0.f, 0.f, 0.f, 0.9f, 1, 0.9f);  // last stride-32 row
  SetYolox(&out, YoloxRow(16, 3, 3), 0.f, 0.f, 0.f, 0.f, 0.9f, 2, 0.2f);   // score 0.18 < 0.3
  auto c = DecodeYolox(out, 416, lb, 0.3f);
  ASSERT_TRUE(c.ok());
  ASSERT_EQ(c->size(), 2u);
  EXPECT_EQ((*c)[0].class_id, 0);
  EXPECT_FLOAT_EQ((*c)[0].box_px.x + 4.f, 51 * 8.f);  // centre at (51 * 8, 0), size 8
  EXPECT_FLOAT_EQ((*c)[1].box_px.y + 16.f, 12 * 32.f);
  EXPECT_FLOAT_EQ((*c)[1].box_px.width, 32.f);
}

TEST(DecodeYolox, WrongShapeIsAnError) {
  const int sizes[] = {1, 100, 85};
  cv::Mat bad(3, sizes, CV_32F, cv::Scalar(0));
  EXPECT_FALSE(DecodeYolox(bad, 416, Letterbox{}, 0.3f).ok());
  EXPECT_FALSE(DecodeYolox(EmptyYolox(), 320, Letterbox{}, 0.3f).ok());
  EXPECT_FALSE(DecodeYolox(cv::Mat(), 416, Letterbox{}, 0.3f).ok());
}

// NanoDet outputs for a 320 input: class maps [N, 80] and box maps [N, 32], shuffled order.
std::vector<cv::Mat> EmptyNanodet() {
  std::vector<cv::Mat> outs;
  for (int s : {32, 8, 16}) {
    const int n = (320 / s) * (320 / s);
    outs.emplace_back(n, 32, CV_32F, cv::Scalar(0.f));
    outs.emplace_back(n, 80, CV_32F, cv::Scalar(0.f));
  }
  return outs;
}

TEST(DecodeNanodet, KnownDistributionGivesKnownBox) {
  cv::Mat image(480, 640, CV_8UC3, cv::Scalar(0));
  Letterbox lb;
  cv::Mat input = LetterboxCentred(image, 320, &lb);
  EXPECT_FLOAT_EQ(lb.scale, 0.5f);
  EXPECT_FLOAT_EQ(lb.pad_y_px, 40.f);  // (320 - 240) / 2
  EXPECT_FLOAT_EQ(lb.pad_x_px, 0.f);

  std::vector<cv::Mat> outs = EmptyNanodet();
  // Stride 16 (N = 400): box map is outs[4], class map outs[5]. Cell (5, 6) -> i = 6 * 20 + 5.
  const int i = 6 * 20 + 5;
  outs[5].at<float>(i, 73) = 0.8f;  // "book"
  // Distances: one-hot logits at bins 2, 3, 4, 5 -> expectation ~ bin (large logit), * 16.
  const int bins[4] = {2, 3, 4, 5};
  for (int k = 0; k < 4; ++k) outs[4].at<float>(i, k * 8 + bins[k]) = 30.f;
  auto c = DecodeNanodet(outs, 320, lb, 0.35f);
  ASSERT_TRUE(c.ok()) << c.status();
  ASSERT_EQ(c->size(), 1u);
  EXPECT_EQ((*c)[0].class_id, 73);
  const float cx = 5 * 16 + 7.5f, cy = 6 * 16 + 7.5f;
  const float x1 = cx - 32, y1 = cy - 48, x2 = cx + 64, y2 = cy + 80;
  EXPECT_NEAR((*c)[0].box_px.x, x1 / 0.5f, 1e-3);
  EXPECT_NEAR((*c)[0].box_px.y, (y1 - 40) / 0.5f, 1e-3);
  EXPECT_NEAR((*c)[0].box_px.width, (x2 - x1) / 0.5f, 1e-3);
  EXPECT_NEAR((*c)[0].box_px.height, (y2 - y1) / 0.5f, 1e-3);
}

TEST(DecodeNanodet, MissingStrideIsAnError) {
  std::vector<cv::Mat> outs = EmptyNanodet();
  outs.pop_back();
  EXPECT_FALSE(DecodeNanodet(outs, 320, Letterbox{}, 0.35f).ok());
  EXPECT_FALSE(DecodeNanodet(EmptyNanodet(), 416, Letterbox{}, 0.35f).ok());
}

TEST(PerClassNms, SuppressesWithinClassOnly) {
  std::vector<Candidate> c = {
      {0, 0.9f, {100, 100, 50, 50}},
      {0, 0.8f, {105, 102, 50, 50}},  // same class, IoU ~0.77 -> suppressed
      {1, 0.7f, {104, 101, 50, 50}},  // other class, same place -> kept
      {0, 0.6f, {300, 300, 40, 40}},  // same class, far -> kept
  };
  std::vector<Candidate> kept = PerClassNms(c, 0.45f);
  ASSERT_EQ(kept.size(), 3u);
  EXPECT_FLOAT_EQ(kept[0].score, 0.9f);
  EXPECT_FLOAT_EQ(kept[1].score, 0.7f);
  EXPECT_EQ(kept[1].class_id, 1);
  EXPECT_FLOAT_EQ(kept[2].score, 0.6f);
}

TEST(BoxIou, KnownValues) {
  EXPECT_FLOAT_EQ(BoxIou({0, 0, 10, 10}, {0, 0, 10, 10}), 1.f);
  EXPECT_FLOAT_EQ(BoxIou({0, 0, 10, 10}, {5, 0, 10, 10}), 50.f / 150.f);
  EXPECT_FLOAT_EQ(BoxIou({0, 0, 10, 10}, {20, 20, 5, 5}), 0.f);
  EXPECT_FLOAT_EQ(BoxIou({0, 0, 0, 0}, {0, 0, 0, 0}), 0.f);
}

}  // namespace
}  // namespace loci::detection
