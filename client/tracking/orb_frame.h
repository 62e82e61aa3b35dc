// One RGB-D frame prepared for tracking: grid-distributed ORB keypoints with descriptors, the
// depth (m) at each keypoint and its 3-D point in the cam frame, and a pixel grid for
// projection search.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <vector>

#include "client/tracking/tracker_options.h"
#include "common/hamming.h"

namespace loci {

struct OrbFrame {
  int64_t t_ns = 0;
  int width_px = 0, height_px = 0;
  std::vector<cv::KeyPoint> keypoints;     // level-0 pixel coordinates
  std::vector<Descriptor256> descriptors;  // one per keypoint
  std::vector<float> depth_m;              // per keypoint, 0 = no valid depth
  std::vector<Eigen::Vector3d> p_cam;      // per keypoint, valid when depth_m > 0
  std::vector<float> class_weight;         // per keypoint: dynamic weight of its box, or -1
  // Keypoint indices per grid cell of kCellPx pixels (projection search).
  static constexpr int kCellPx = 16;
  int grid_cols = 0, grid_rows = 0;
  std::vector<std::vector<int>> grid;

  size_t size() const { return keypoints.size(); }
  // Keypoints within radius_px of (u, v) whose octave is in [min_level, max_level].
  void FeaturesInRadius(double u, double v, double radius_px, int min_level, int max_level,
                        std::vector<int>* out) const;
};

// Detects ORB keypoints on `gray` (CV_8UC1) and distributes them over a grid of cells so that
// texture-poor regions still get features; samples depth from `depth_m` (CV_32FC1, 0 = none).
class OrbExtractor {
 public:
  explicit OrbExtractor(const TrackerOptions& options);
  OrbFrame Extract(const cv::Mat& gray, const cv::Mat& depth_m, int64_t t_ns) const;
  // Scale of an octave relative to level 0.
  float LevelScale(int octave) const;

 private:
  TrackerOptions opt_;
  cv::Ptr<cv::ORB> orb_;
  std::vector<float> level_scale_;
};

}  // namespace loci
