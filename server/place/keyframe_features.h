// ORB features of one keyframe, extracted on the server from the stored images, with a 3D point
// per keypoint from the depth image in the keyframe's camera frame (kf: x right, y down,
// z forward, metres). What place recognition (bag of words) and geometric verification (PnP
// with depth, 3D-3D alignment) need of a keyframe; stored per keyframe (feature_codec.h).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string_view>
#include <vector>

#include "common/camera.h"
#include "common/status.h"
#include "server/place/place_options.h"

namespace loci::place {

// ORB descriptors are 256 bits.
inline constexpr int kDescriptorBytes = 32;

struct KeyframeFeatures {
  PinholeCamera camera;                // intrinsics of the image the keypoints are in
  std::vector<Eigen::Vector2f> uv_px;  // keypoint positions at full resolution, px
  std::vector<uint8_t> octave;         // pyramid level each keypoint was found at
  float level_scale = 1.2f;            // size ratio of consecutive pyramid levels
  cv::Mat descriptors;                 // CV_8UC1, one 32-byte ORB descriptor per row
  // The keypoint's point in the keyframe's camera frame from the depth image, m; z == 0 when
  // the pixel has no depth in [min_depth_m, max_depth_m].
  std::vector<Eigen::Vector3f> p_kf_m;

  size_t size() const { return uv_px.size(); }
  bool HasDepth(size_t i) const { return p_kf_m[i].z() > 0; }
  // Position noise of keypoint i: sigma_px at level 0, times level_scale per level.
  double PixelSigma(size_t i, double sigma_px) const;
  // Number of keypoints with a 3D point.
  size_t CountWithDepth() const;
  // Sizes of the arrays agree and descriptors are CV_8UC1 with 32 columns.
  Status CheckConsistent() const;
};

// Features of a decoded keyframe: `bgr` CV_8UC3 (or CV_8UC1 grey), depth_m CV_32FC1 of the same
// size in metres (0 = no reading), registered to the colour image.
StatusOr<KeyframeFeatures> ExtractFeatures(const cv::Mat& bgr, const cv::Mat& depth_m,
                                           const PinholeCamera& camera,
                                           const FeatureOptions& options);

// Features of a stored keyframe: its JPEG, its 16-bit depth PNG (depth_scale units per metre,
// TUM: 5000) and its intrinsics.
StatusOr<KeyframeFeatures> ExtractFeaturesFromEncoded(std::string_view rgb_jpeg,
                                                      std::string_view depth_png,
                                                      double depth_scale,
                                                      const PinholeCamera& camera,
                                                      const FeatureOptions& options);

}  // namespace loci::place
