// Image codecs: 8-bit BGR JPEG for colour, 16-bit single-channel PNG for depth. Every decoder
// first checks the header (format by magic bytes, declared size, a complete stream; see
// image_header.h), then decodes (JPEG: libjpeg with warnings as errors; PNG: OpenCV, whose
// libpng checks CRCs), and returns a clear InvalidArgument on corrupt or unexpected input.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include <opencv2/core.hpp>

#include "common/status.h"

namespace loci {

// JPEG bytes of an 8-bit BGR (CV_8UC3) image. quality in [1, 100].
StatusOr<std::string> EncodeJpeg(const cv::Mat& bgr, int quality = 90);
// Decodes JPEG bytes to CV_8UC3 BGR. Checks the size when expected_* > 0.
StatusOr<cv::Mat> DecodeJpeg(std::string_view bytes, int expected_width = 0,
                             int expected_height = 0);

// 16-bit PNG bytes of a CV_16UC1 depth image (raw units, e.g. TUM: 5000 per metre).
StatusOr<std::string> EncodeDepthPng(const cv::Mat& depth_u16);
// Decodes a 16-bit single-channel PNG to CV_16UC1 (rejects 8-bit or colour PNGs).
StatusOr<cv::Mat> DecodeDepthPng(std::string_view bytes, int expected_width = 0,
                                 int expected_height = 0);
// 8-bit single-channel PNG (masks); the decoder refuses a declared size over max_* (when > 0).
StatusOr<std::string> EncodeMaskPng(const cv::Mat& mask_u8);
StatusOr<cv::Mat> DecodeMaskPng(std::string_view bytes, int max_width = 0, int max_height = 0);

// Raw depth (CV_16UC1) to metres (CV_32FC1); 0 (no measurement) becomes 0.
cv::Mat DepthToMetres(const cv::Mat& depth_u16, double depth_scale);

// Reads a whole file into a string.
StatusOr<std::string> ReadFileBytes(const std::string& path);
Status WriteFileBytes(const std::string& path, std::string_view bytes);

}  // namespace loci
