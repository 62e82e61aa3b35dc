// Object masks from a box and a registered depth image (paper 002, section 3.3): the dominant
// depth cluster inside the box, so the wall or floor behind the object is left out.
#pragma once

#include <yaml-cpp/yaml.h>

#include <opencv2/core.hpp>
#include <vector>

#include "common/detections_io.h"
#include "common/status.h"

namespace loci::detection {

struct MaskOptions {
  // Raw depth units per metre for CV_16U depth (TUM: 5000). Ignored for CV_32F (metres).
  float depth_scale = 5000.f;
  // Valid depth range, metres; other values (0 = no reading) are ignored. Default 0.1-10 m.
  float min_depth_m = 0.1f;
  float max_depth_m = 10.f;
  // Histogram bin width relative to depth (log-depth bins, since RGB-D noise grows with
  // depth). Default 0.02 = 2 cm at 1 m, 6 cm at 3 m.
  float bin_width_rel = 0.02f;
  // Pixels are weighted by a Gaussian around the box centre, sigma = this fraction of the box
  // width / height, so the cluster the object fills at its centre wins over a larger
  // background visible around it. Default 0.3.
  float centre_sigma_rel = 0.3f;
  // The cluster grows from the peak bin over bins holding at least this fraction of the peak
  // weight, bridging at most max_gap_bins weaker bins. Defaults 0.02 and 2.
  float min_bin_fraction = 0.02f;
  int max_gap_bins = 2;
  // Fewer valid pixels than this in the box -> all-zero mask. Default 20.
  int min_pixels = 20;
  // Keep only the connected component carrying the most centre weight. Default true.
  bool largest_component = true;
  // Side of the square kernel used to open (remove speckle) and close (fill depth holes)
  // the mask, pixels; 0 or 1 = no morphology. Default 3.
  int morph_kernel_px = 3;

  // Support-plane removal: a plane fitted (RANSAC on inverse depth, which is affine in the
  // pixel coordinates for any plane) to the mask pixels near the box border is removed when
  // it does not also cover the box centre: the table under a keyboard, the floor behind a
  // chair. Default true.
  bool remove_support_plane = true;
  // Plane inlier tolerance: max(plane_tolerance_m, plane_tolerance_sigma * sigma(z)) with the
  // Kinect noise sigma(z) = 0.0015 z^2 m. Defaults 0.008 m and 2.5.
  float plane_tolerance_m = 0.008f;
  float plane_tolerance_sigma = 2.5f;

  static StatusOr<MaskOptions> FromYaml(const YAML::Node& node);
  Status Validate() const;
};

// Mask (CV_8UC1, 255 = object) covering MaskRect(box_px, depth.cols, depth.rows), for depth
// CV_16U (raw, scaled by depth_scale) or CV_32F (metres) registered to the image of the box.
// All zeros when the box has too little valid depth; empty Mat when the box misses the image
// or the depth type is unsupported.
cv::Mat SegmentObjectDepth(const cv::Mat& depth, const cv::Rect2f& box_px,
                           const MaskOptions& options);

// Sets Detection2D::mask on each detection with a non-empty segmentation; the others keep no
// mask (box only).
void AttachDepthMasks(const cv::Mat& depth, std::vector<Detection2D>* detections,
                      const MaskOptions& options);

}  // namespace loci::detection
