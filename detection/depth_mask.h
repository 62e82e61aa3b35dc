// Object masks from a box and a registered depth image (paper 002, section 3.3): the dominant
// depth cluster inside the box, so the wall or floor behind the object is left out.
#pragma once

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/camera.h"
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

  // Background-plane removal before clustering (background_planes.h): planes found by
  // sequential RANSAC in the box that continue outside it (the table under a keyboard, the floor
  // under a table, the wall behind a cup) are left out of the mask. Default true.
  bool remove_support_plane = true;
  // Plane inlier tolerance: max(plane_tolerance_m, plane_tolerance_sigma * sigma(z)) with the
  // Kinect noise sigma(z) = 0.0015 z^2 m. Defaults 0.008 m and 2.5.
  float plane_tolerance_m = 0.008f;
  float plane_tolerance_sigma = 2.5f;
  // At most this many planes are tried per box; a plane needs at least min_plane_support of the
  // box's valid pixels. Defaults 3 and 0.1.
  int max_background_planes = 3;
  float min_plane_support = 0.1f;
  // A plane is background when at least this fraction of the valid pixels in a ring just
  // outside the box lie on it. Default 0.25.
  float min_outside_fraction = 0.25f;
  // ... and when it holds less than this fraction of the valid pixels in the central 40 % x 40 %
  // of the box (else it is the object's own face, or an object too thin to tell from its
  // support). Default 0.5.
  float max_centre_fraction = 0.5f;
  // Planes are kept (not removed) when removing them would leave less than this fraction of
  // the box's valid pixels. Default 0.05.
  float min_object_fraction = 0.05f;
  // With gravity and intrinsics (MaskContext): a horizontal plane (normal within
  // horizontal_max_deg of gravity) with part of the object above it and nothing of the box
  // more than 3 cm below it (measured from the plane) is the support the object stands on and
  // is removed, even where the box is cut by the image border so that the ring test cannot see
  // it continue. A support that continues outside the box is removed even when it holds the
  // box centre (a loose box over a keyboard and the desk around it), and for objects that are
  // not furniture what lies below it does not count (the floor past the desk's edge). Furniture that is itself a support (support_classes) keeps
  // its top: only a horizontal plane with such a top at least support_min_rise_m above it is
  // removed (the floor under a table). Defaults 20 deg, 0.2 m, the COCO support furniture.
  float horizontal_max_deg = 20.f;
  float support_min_rise_m = 0.2f;
  std::vector<std::string> support_classes = {"dining table", "bed", "couch", "bench"};
  // Support furniture whose top is its highest part: what rises above the top is other objects
  // standing on it (the cups on a table), left out of its mask. Default: dining table, bench.
  std::vector<std::string> flat_top_classes = {"dining table", "bench"};
  // ... precisely: what rises more than this above the top, m. A top is flat to depth noise
  // (about 1 cm at 2 m), while a book lying on it is 2 cm thick or more. Default 0.03.
  float flat_top_margin_m = 0.03f;
  // With gravity and intrinsics: a box of an object that is no support furniture whose centre
  // lies on a level plane that goes on outside the box, with nothing of the box rising 3 cm above
  // it, shows only that surface (sheets of paper on a desk called "book"): the mask is empty.
  // Only where the plane tolerance at the box centre's depth is at most this, so that an object
  // lying on the surface would stand out of it (Kinect: up to about 2 m for 0.015). 0 = off.
  // thin_classes lie flatter than that (a phone, cutlery) and keep the surface as their mask.
  float bare_support_max_tolerance_m = 0.015f;
  std::vector<std::string> thin_classes = {"cell phone", "remote", "knife",
                                           "fork",       "spoon",  "scissors"};

  bool IsSupportClass(const std::string& class_name) const;
  bool IsFlatTopClass(const std::string& class_name) const;
  bool IsThinClass(const std::string& class_name) const;
  static StatusOr<MaskOptions> FromYaml(const YAML::Node& node);
  Status Validate() const;
};

// What is known about the frame and the object besides its box; every field is optional.
struct MaskContext {
  std::string class_name;
  std::optional<PinholeCamera> camera;         // intrinsics of the depth image
  std::optional<Eigen::Vector3d> gravity_cam;  // unit, pointing down, camera frame
};

// Mask (CV_8UC1, 255 = object) covering MaskRect(box_px, depth.cols, depth.rows), for depth
// CV_16U (raw, scaled by depth_scale) or CV_32F (metres) registered to the image of the box.
// All zeros when the box has too little valid depth or shows only a bare support
// (bare_support_max_tolerance_m); empty Mat when the box misses the image
// or the depth type is unsupported.
cv::Mat SegmentObjectDepth(const cv::Mat& depth, const cv::Rect2f& box_px,
                           const MaskOptions& options, const MaskContext& context = {});

// Sets Detection2D::mask on each detection that has none and gets a non-empty segmentation;
// the others keep what they had (their own mask, or none: box only). camera and gravity_cam
// (optional) as in MaskContext.
void AttachDepthMasks(const cv::Mat& depth, std::vector<Detection2D>* detections,
                      const MaskOptions& options,
                      const std::optional<PinholeCamera>& camera = std::nullopt,
                      const std::optional<Eigen::Vector3d>& gravity_cam = std::nullopt);

}  // namespace loci::detection
