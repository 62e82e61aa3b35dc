#include "server/place/keyframe_features.h"

#include <algorithm>
#include <cmath>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "common/image_codec.h"

namespace loci::place {
namespace {

// Depth at a keypoint: the reading at its nearest pixel when within the range, else 0.
float DepthAt(const cv::Mat& depth_m, const cv::Point2f& pt, const FeatureOptions& options) {
  const int u = static_cast<int>(std::lround(pt.x));
  const int v = static_cast<int>(std::lround(pt.y));
  if (u < 0 || v < 0 || u >= depth_m.cols || v >= depth_m.rows) return 0.0f;
  const float z = depth_m.at<float>(v, u);
  return (std::isfinite(z) && z >= options.min_depth_m && z <= options.max_depth_m) ? z : 0.0f;
}

cv::Mat Grey(const cv::Mat& image) {
  if (image.channels() == 1) return image;
  cv::Mat grey;
  cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  return grey;
}

}  // namespace

double KeyframeFeatures::PixelSigma(size_t i, double sigma_px) const {
  return sigma_px * std::pow(static_cast<double>(level_scale), octave[i]);
}

size_t KeyframeFeatures::CountWithDepth() const {
  size_t n = 0;
  for (size_t i = 0; i < size(); ++i) n += HasDepth(i) ? 1 : 0;
  return n;
}

Status KeyframeFeatures::CheckConsistent() const {
  const size_t n = uv_px.size();
  if (octave.size() != n || p_kf_m.size() != n || static_cast<size_t>(descriptors.rows) != n) {
    return absl::InvalidArgumentError("keyframe features: array sizes differ");
  }
  if (n > 0 && (descriptors.type() != CV_8UC1 || descriptors.cols != kDescriptorBytes)) {
    return absl::InvalidArgumentError("keyframe features: descriptors must be CV_8UC1 x 32");
  }
  return absl::OkStatus();
}

StatusOr<KeyframeFeatures> ExtractFeatures(const cv::Mat& bgr, const cv::Mat& depth_m,
                                           const PinholeCamera& camera,
                                           const FeatureOptions& options) {
  if (bgr.empty() || bgr.depth() != CV_8U || (bgr.channels() != 3 && bgr.channels() != 1)) {
    return absl::InvalidArgumentError("features: image must be 8-bit BGR or grey");
  }
  if (depth_m.type() != CV_32FC1 || depth_m.size() != bgr.size()) {
    return absl::InvalidArgumentError("features: depth must be CV_32FC1 of the image's size");
  }
  LOCI_RETURN_IF_ERROR(camera.Validate());
  const cv::Ptr<cv::ORB> orb =
      cv::ORB::create(options.max_features, static_cast<float>(options.scale_factor),
                      options.levels, 31, 0, 2, cv::ORB::HARRIS_SCORE, 31, options.fast_threshold);
  std::vector<cv::KeyPoint> keypoints;
  KeyframeFeatures out;
  orb->detectAndCompute(Grey(bgr), cv::noArray(), keypoints, out.descriptors);
  out.camera = camera;
  out.level_scale = static_cast<float>(options.scale_factor);
  out.uv_px.reserve(keypoints.size());
  out.octave.reserve(keypoints.size());
  out.p_kf_m.reserve(keypoints.size());
  for (const cv::KeyPoint& kp : keypoints) {
    out.uv_px.emplace_back(kp.pt.x, kp.pt.y);
    out.octave.push_back(static_cast<uint8_t>(std::clamp(kp.octave, 0, 255)));
    const float z = DepthAt(depth_m, kp.pt, options);
    out.p_kf_m.push_back(
        z > 0 ? Eigen::Vector3f(camera.BackProject(kp.pt.x, kp.pt.y, z).cast<float>())
              : Eigen::Vector3f::Zero());
  }
  if (keypoints.empty()) out.descriptors = cv::Mat(0, kDescriptorBytes, CV_8UC1);
  return out;
}

StatusOr<KeyframeFeatures> ExtractFeaturesFromEncoded(std::string_view rgb_jpeg,
                                                      std::string_view depth_png,
                                                      double depth_scale,
                                                      const PinholeCamera& camera,
                                                      const FeatureOptions& options) {
  if (!(depth_scale > 0)) return absl::InvalidArgumentError("features: depth_scale must be > 0");
  LOCI_ASSIGN_OR_RETURN(const cv::Mat bgr, DecodeJpeg(rgb_jpeg));
  LOCI_ASSIGN_OR_RETURN(const cv::Mat depth_u16, DecodeDepthPng(depth_png, bgr.cols, bgr.rows));
  return ExtractFeatures(bgr, DepthToMetres(depth_u16, depth_scale), camera, options);
}

}  // namespace loci::place
