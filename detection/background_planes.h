// Background planes inside an object box: surfaces that continue outside the box (the table
// under a keyboard, the floor under a table, the wall behind a cup). Used by SegmentObjectDepth
// before the depth clustering, so an object's mask leaves out its support and background even
// where they touch it at the same depth.
#pragma once

#include <opencv2/core.hpp>

#include "detection/depth_mask.h"

namespace loci::detection {

// Plane in a pinhole depth image: inverse depth is affine in pixel coordinates for any 3-D plane,
// 1/z = a u + b v + c, so planes are fitted without the camera intrinsics.
struct InverseDepthPlane {
  double a = 0, b = 0, c = 0;
  // Through three (u, v, z) points; false when they are (nearly) collinear.
  bool Fit3(const cv::Point3d& p, const cv::Point3d& q, const cv::Point3d& r);
  // Least squares on depth residuals (inverse-depth residuals weighted by z^2); false when
  // degenerate.
  bool Refit(const std::vector<cv::Point3d>& points);
  // Depth of the plane at (u, v), metres; <= 0 when the plane is behind the camera there.
  double DepthAt(double u, double v) const;
};

// Inlier tolerance for a plane at depth z_m: max(plane_tolerance_m, plane_tolerance_sigma *
// 0.0015 z^2), the latter being the Kinect axial noise.
double PlaneToleranceM(double z_m, const MaskOptions& o);

// Depth in metres at (u, v) of a CV_16U (raw, / depth_scale) or CV_32F image; 0 when outside
// [min_depth_m, max_depth_m] or missing.
double ValidDepthM(const cv::Mat& depth, int u, int v, const MaskOptions& o);

// Mask over `roi` (CV_8UC1, 255 = pixel on a background plane). depth is the whole image and
// depth_m its roi in metres (CV_32F, 0 = invalid). Up to max_background_planes planes are found
// by sequential RANSAC over the box's pixels; a plane is background when at least a quarter of
// the valid pixels in a ring just outside the box lie on it (a detector's box is tight on its
// object: a surface that goes on past the box is not the object's). All zeros when removing the
// planes would leave almost nothing (an object too thin to tell from its support, such as a
// phone lying on a table far away): the caller then segments by depth alone.
// With gravity and intrinsics in `context`, horizontal support planes are background too (see
// MaskOptions::horizontal_max_deg), and bare_support tells a box that shows only its support
// (MaskOptions::bare_support_max_tolerance_m; the mask is then all zeros).
struct BackgroundPlanes {
  cv::Mat mask;
  bool bare_support = false;
};
BackgroundPlanes BackgroundPlaneMask(const cv::Mat& depth, const cv::Rect& roi,
                                     const cv::Mat& depth_m, const MaskOptions& o,
                                     const MaskContext& context = {});

}  // namespace loci::detection
