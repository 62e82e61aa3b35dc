#include "common/image_codec.h"

#include <fstream>
#include <sstream>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "common/image_header.h"
#include "common/jpeg_strict.h"

namespace loci {
namespace {

StatusOr<cv::Mat> Decode(std::string_view bytes, int flags, const char* what) {
  if (bytes.empty()) return absl::InvalidArgumentError(absl::StrCat(what, ": empty image"));
  const cv::Mat buf(1, static_cast<int>(bytes.size()), CV_8UC1,
                    const_cast<char*>(bytes.data()));
  cv::Mat img;
  try {
    img = cv::imdecode(buf, flags);
  } catch (const cv::Exception& e) {
    return absl::InvalidArgumentError(absl::StrCat(what, ": cannot decode: ", e.what()));
  }
  if (img.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(what, ": cannot decode (corrupt or not an image)"));
  }
  return img;
}

Status CheckSize(const cv::Mat& img, int w, int h, const char* what) {
  if ((w > 0 && img.cols != w) || (h > 0 && img.rows != h)) {
    return absl::InvalidArgumentError(absl::StrCat(what, ": size ", img.cols, "x", img.rows,
                                                   " differs from the declared ", w, "x", h));
  }
  return absl::OkStatus();
}

// Reads and checks the header of `bytes` before anything is decoded.
StatusOr<ImageHeader> CheckedHeader(std::string_view bytes, ImageFormat format, int w, int h,
                                    const char* what) {
  auto header = ReadImageHeader(bytes);
  if (!header.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(what, ": ", header.status().message()));
  }
  LOCI_RETURN_IF_ERROR(CheckImageHeader(*header, format, w, h, what));
  return header;
}

StatusOr<std::string> Encode(const char* ext, const cv::Mat& img, const std::vector<int>& params) {
  std::vector<uchar> out;
  try {
    if (!cv::imencode(ext, img, out, params)) {
      return absl::InternalError(absl::StrCat("cannot encode ", ext));
    }
  } catch (const cv::Exception& e) {
    return absl::InvalidArgumentError(absl::StrCat("cannot encode ", ext, ": ", e.what()));
  }
  return std::string(out.begin(), out.end());
}

}  // namespace

StatusOr<std::string> EncodeJpeg(const cv::Mat& bgr, int quality) {
  if (bgr.type() != CV_8UC3) return absl::InvalidArgumentError("EncodeJpeg needs CV_8UC3");
  return Encode(".jpg", bgr, {cv::IMWRITE_JPEG_QUALITY, std::clamp(quality, 1, 100)});
}

StatusOr<cv::Mat> DecodeJpeg(std::string_view bytes, int expected_width, int expected_height) {
  LOCI_RETURN_IF_ERROR(
      CheckedHeader(bytes, ImageFormat::kJpeg, expected_width, expected_height, "rgb").status());
  auto img = DecodeJpegStrict(bytes);
  if (!img.ok()) return absl::InvalidArgumentError(absl::StrCat("rgb: ", img.status().message()));
  LOCI_RETURN_IF_ERROR(CheckSize(*img, expected_width, expected_height, "rgb"));
  return img;
}

StatusOr<std::string> EncodeDepthPng(const cv::Mat& depth_u16) {
  if (depth_u16.type() != CV_16UC1) {
    return absl::InvalidArgumentError("EncodeDepthPng needs CV_16UC1");
  }
  return Encode(".png", depth_u16, {cv::IMWRITE_PNG_COMPRESSION, 1});
}

StatusOr<cv::Mat> DecodeDepthPng(std::string_view bytes, int expected_width,
                                 int expected_height) {
  LOCI_ASSIGN_OR_RETURN(
      ImageHeader header,
      CheckedHeader(bytes, ImageFormat::kPng, expected_width, expected_height, "depth"));
  if (header.bit_depth != 16 || header.channels != 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("depth: expected a 16-bit single-channel PNG, got ", header.channels,
                     " channel(s) of ", header.bit_depth, "-bit"));
  }
  LOCI_ASSIGN_OR_RETURN(cv::Mat img, Decode(bytes, cv::IMREAD_UNCHANGED, "depth"));
  if (img.type() != CV_16UC1) {
    return absl::InvalidArgumentError("depth: the PNG did not decode to 16-bit single-channel");
  }
  LOCI_RETURN_IF_ERROR(CheckSize(img, expected_width, expected_height, "depth"));
  return img;
}

StatusOr<std::string> EncodeMaskPng(const cv::Mat& mask_u8) {
  if (mask_u8.type() != CV_8UC1) return absl::InvalidArgumentError("EncodeMaskPng needs CV_8UC1");
  return Encode(".png", mask_u8, {cv::IMWRITE_PNG_COMPRESSION, 1});
}

StatusOr<cv::Mat> DecodeMaskPng(std::string_view bytes, int max_width, int max_height) {
  LOCI_ASSIGN_OR_RETURN(ImageHeader header,
                        CheckedHeader(bytes, ImageFormat::kPng, 0, 0, "mask"));
  if ((max_width > 0 && header.width_px > max_width) ||
      (max_height > 0 && header.height_px > max_height)) {
    return absl::InvalidArgumentError(absl::StrCat("mask: declared size ", header.width_px, "x",
                                                   header.height_px, " exceeds ", max_width, "x",
                                                   max_height));
  }
  return Decode(bytes, cv::IMREAD_GRAYSCALE, "mask");
}

cv::Mat DepthToMetres(const cv::Mat& depth_u16, double depth_scale) {
  cv::Mat out;
  depth_u16.convertTo(out, CV_32F, 1.0 / depth_scale);
  return out;
}

StatusOr<std::string> ReadFileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat("cannot open ", path));
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

Status WriteFileBytes(const std::string& path, std::string_view bytes) {
  std::ofstream out(path, std::ios::binary);
  if (!out) return absl::PermissionDeniedError(absl::StrCat("cannot write ", path));
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!out) return absl::DataLossError(absl::StrCat("short write to ", path));
  return absl::OkStatus();
}

}  // namespace loci
