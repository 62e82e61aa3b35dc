#include "common/image_codec.h"

#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

namespace loci {
namespace {

TEST(ImageCodec, DepthPngRoundTripIsLossless) {
  cv::Mat depth(48, 64, CV_16UC1);
  cv::randu(depth, 0, 65535);
  auto png = EncodeDepthPng(depth);
  ASSERT_TRUE(png.ok());
  auto back = DecodeDepthPng(*png, 64, 48);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(cv::norm(depth, *back, cv::NORM_INF), 0.0);
}

TEST(ImageCodec, JpegRoundTripKeepsSizeAndContent) {
  cv::Mat bgr(60, 80, CV_8UC3, cv::Scalar(40, 120, 200));
  cv::circle(bgr, {40, 30}, 10, cv::Scalar(255, 255, 255), -1);
  auto jpg = EncodeJpeg(bgr, 95);
  ASSERT_TRUE(jpg.ok());
  auto back = DecodeJpeg(*jpg);
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(back->size(), bgr.size());
  EXPECT_LT(cv::norm(bgr, *back, cv::NORM_L1) / bgr.total(), 6.0);
}

TEST(ImageCodec, CorruptAndWrongInputsGiveClearErrors) {
  auto bad = DecodeJpeg(std::string("\xff\xd8\xff garbage bytes", 17));
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(bad.status().message().find("rgb"), std::string::npos);
  EXPECT_FALSE(DecodeJpeg("").ok());

  // A truncated valid JPEG must not crash.
  cv::Mat bgr(32, 32, CV_8UC3, cv::Scalar(1, 2, 3));
  std::string jpg = *EncodeJpeg(bgr);
  EXPECT_FALSE(DecodeJpeg(jpg.substr(0, 20)).ok());

  // An 8-bit PNG is not depth; a wrong size is reported.
  cv::Mat mask(10, 10, CV_8UC1, cv::Scalar(3));
  auto eight_bit = DecodeDepthPng(*EncodeMaskPng(mask));
  ASSERT_FALSE(eight_bit.ok());
  EXPECT_NE(eight_bit.status().message().find("16-bit"), std::string::npos);
  cv::Mat depth(10, 10, CV_16UC1, cv::Scalar(1000));
  auto wrong = DecodeDepthPng(*EncodeDepthPng(depth), 640, 480);
  ASSERT_FALSE(wrong.ok());
  EXPECT_NE(wrong.status().message().find("10x10"), std::string::npos);
}

TEST(ImageCodec, DepthToMetresUsesScale) {
  cv::Mat depth(1, 2, CV_16UC1);
  depth.at<uint16_t>(0, 0) = 5000;
  depth.at<uint16_t>(0, 1) = 0;
  cv::Mat m = DepthToMetres(depth, 5000.0);
  EXPECT_FLOAT_EQ(m.at<float>(0, 0), 1.0f);
  EXPECT_FLOAT_EQ(m.at<float>(0, 1), 0.0f);
}

}  // namespace
}  // namespace loci
