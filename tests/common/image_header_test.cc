#include "common/image_header.h"

#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/image_codec.h"

namespace loci {
namespace {

// A real camera frame stand-in: gradients and a disc, so the JPEG has a non-trivial scan.
cv::Mat TestImage() {
  cv::Mat bgr(120, 160, CV_8UC3);
  for (int r = 0; r < bgr.rows; ++r) {
    for (int c = 0; c < bgr.cols; ++c) bgr.at<cv::Vec3b>(r, c) = cv::Vec3b(r, c, (r * c) % 255);
  }
  cv::circle(bgr, {80, 60}, 30, cv::Scalar(255, 255, 255), -1);
  return bgr;
}

// Offset of the first SOF0 frame header's height field in a JPEG.
size_t SofHeightOffset(const std::string& jpg) { return jpg.find("\xFF\xC0") + 5; }

TEST(ImageHeader, ReadsFormatSizeAndCompletenessWithoutDecoding) {
  const std::string jpg = *EncodeJpeg(TestImage());
  auto h = ReadImageHeader(jpg);
  ASSERT_TRUE(h.ok()) << h.status();
  EXPECT_EQ(h->format, ImageFormat::kJpeg);
  EXPECT_EQ(h->width_px, 160);
  EXPECT_EQ(h->height_px, 120);
  EXPECT_EQ(h->channels, 3);
  EXPECT_TRUE(h->complete);

  const std::string png = *EncodeDepthPng(cv::Mat(48, 64, CV_16UC1, cv::Scalar(1000)));
  h = ReadImageHeader(png);
  ASSERT_TRUE(h.ok()) << h.status();
  EXPECT_EQ(h->format, ImageFormat::kPng);
  EXPECT_EQ(h->width_px, 64);
  EXPECT_EQ(h->height_px, 48);
  EXPECT_EQ(h->bit_depth, 16);
  EXPECT_EQ(h->channels, 1);
  EXPECT_TRUE(h->complete);
  EXPECT_FALSE(ReadImageHeader(png.substr(0, png.size() - 12))->complete);
}

TEST(ImageHeader, OtherFormatsAreRefusedByTheirMagicBytes) {
  std::vector<uchar> tiff, pgm;
  cv::imencode(".tiff", cv::Mat(8, 8, CV_16UC1, cv::Scalar(7)), tiff);
  cv::imencode(".pgm", cv::Mat(8, 8, CV_16UC1, cv::Scalar(7)), pgm);
  for (const auto& bytes : {tiff, pgm}) {
    auto h = ReadImageHeader(std::string(bytes.begin(), bytes.end()));
    ASSERT_FALSE(h.ok());
    EXPECT_NE(h.status().message().find("neither JPEG nor PNG"), std::string::npos);
  }
  auto depth_as_tiff = DecodeDepthPng(std::string(tiff.begin(), tiff.end()), 8, 8);
  ASSERT_FALSE(depth_as_tiff.ok());
  EXPECT_NE(depth_as_tiff.status().message().find("depth"), std::string::npos);
  const std::string png = *EncodeMaskPng(cv::Mat(8, 8, CV_8UC1, cv::Scalar(1)));
  auto png_as_jpeg = DecodeJpeg(png);
  ASSERT_FALSE(png_as_jpeg.ok());
  EXPECT_NE(png_as_jpeg.status().message().find("expected JPEG, got PNG"), std::string::npos);
}

TEST(ImageHeader, AHugeDeclaredSizeIsRefusedBeforeDecoding) {
  // A small JPEG whose frame header claims 32000 x 32000 pixels (a decompression bomb).
  std::string jpg = *EncodeJpeg(TestImage());
  const size_t at = SofHeightOffset(jpg);
  jpg[at] = jpg[at + 2] = static_cast<char>(32000 >> 8);
  jpg[at + 1] = jpg[at + 3] = static_cast<char>(32000 & 0xff);
  auto free_size = DecodeJpeg(jpg);
  ASSERT_FALSE(free_size.ok());
  EXPECT_NE(free_size.status().message().find("exceeds"), std::string::npos);
  auto camera_size = DecodeJpeg(jpg, 640, 480);
  ASSERT_FALSE(camera_size.ok());
  EXPECT_NE(camera_size.status().message().find("declared size 32000x32000"), std::string::npos);
  const std::string mask = *EncodeMaskPng(cv::Mat(50, 40, CV_8UC1, cv::Scalar(1)));
  EXPECT_TRUE(DecodeMaskPng(mask, 41, 51).ok());
  EXPECT_FALSE(DecodeMaskPng(mask, 30, 51).ok());
}

TEST(ImageHeader, TruncatedOrCorruptJpegsAreNotDecodedIntoGreyBlocks) {
  const std::string jpg = *EncodeJpeg(TestImage());
  ASSERT_TRUE(DecodeJpeg(jpg, 160, 120).ok());
  // Cut in the scan: no end marker.
  auto cut = DecodeJpeg(jpg.substr(0, jpg.size() / 2), 160, 120);
  ASSERT_FALSE(cut.ok());
  EXPECT_NE(cut.status().message().find("truncated"), std::string::npos);
  // Cut in the scan with an end marker appended: libjpeg would fill the rest with grey.
  auto cut_eoi = DecodeJpeg(jpg.substr(0, jpg.size() / 2) + "\xFF\xD9", 160, 120);
  ASSERT_FALSE(cut_eoi.ok());
  EXPECT_NE(cut_eoi.status().message().find("corrupt JPEG"), std::string::npos);
  // Bytes overwritten in the middle of the scan by a stray marker.
  std::string flipped = jpg;
  flipped.replace(flipped.size() / 2, 4, "\xFF\xD3\xFF\xD5");
  auto corrupt = DecodeJpeg(flipped, 160, 120);
  ASSERT_FALSE(corrupt.ok());
  EXPECT_NE(corrupt.status().message().find("corrupt JPEG"), std::string::npos);
}

}  // namespace
}  // namespace loci
