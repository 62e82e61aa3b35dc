// Negative evidence: whether an object of the map should have been detected in a keyframe. An
// object is expected when enough of its points project inside the image, in depth range and
// not hidden (the keyframe's own depth at the pixel is not nearer than the point by more than
// a tolerance plus the object's own size, so its far side does not hide it), and its
// projection is large enough for the detector to find. A detection of any class over its
// projection (a confusable class, a score below the map's threshold) excuses it.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <vector>

#include "common/camera.h"
#include "common/detections_io.h"
#include "common/se3.h"

namespace loci::server {

struct VisibilityOptions {
  // Share of the object's sample points that must be visible (0.6).
  double min_visible_fraction = 0.6;
  // A point is hidden when the keyframe's depth at its pixel is nearer by more than
  // occlusion_tol_m + occlusion_tol_rel * depth + the object's half size (0.04 m + 3 %).
  double occlusion_tol_m = 0.04;
  double occlusion_tol_rel = 0.03;
  int border_px = 10;             // points this close to the image border do not count (10)
  double min_projected_px = 32;   // the projection's larger side must reach this, px (32)
  double max_depth_m = 4.0;       // farther points do not count (4.0)
  double excuse_iou = 0.3;        // a detection box overlapping the projection this much excuses (0.3)
  // The keyframe depth kept for this test (and stored with its products) holds every n-th
  // pixel in u and v (4).
  int depth_stride = 4;
};

struct KeyframeView {
  const PinholeCamera* camera = nullptr;  // of the full image
  // CV_32FC1, 0 = invalid: every depth_stride-th pixel of the keyframe's depth
  // (SubsampleDepth).
  const cv::Mat* depth_m = nullptr;
  int depth_stride = 1;
  SE3d T_kf_map = SE3d::Identity();
  const std::vector<Detection2D>* detections = nullptr;  // every detection of the keyframe
};

// Every stride-th pixel of a depth image in u and v (nearest, no averaging across edges).
cv::Mat SubsampleDepth(const cv::Mat& depth_m, int stride);

// True when the object (sample points in the map frame) should have been detected here.
// size_m: the object's largest half extent (its self-occlusion allowance).
bool ExpectedInView(const std::vector<Eigen::Vector3d>& sample_m, double size_m,
                    const KeyframeView& view, const VisibilityOptions& options);

}  // namespace loci::server
