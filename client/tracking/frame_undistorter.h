// loci::FrameUndistorter: removes a sensor's lens distortion from a frame's colour image and its
// registered depth image, so that everything after it (odometry, detection, the streamed
// keyframes, the server) works with the pinhole intrinsics alone. The output keeps the camera's
// K and size; pixels that fall outside the raw image get the nearest border colour and no depth.
//
//   FrameUndistorter undistort(options.camera, options.distortion);  // identity when zero
//   LOCI_RETURN_IF_ERROR(undistort.Apply(&bgr, &depth_u16));
//
// The depth image is resampled with the colour image's map, nearest neighbour (a depth is never
// interpolated across an edge): registered to the raw colour image, it stays registered.
#pragma once

#include <opencv2/core.hpp>

#include "common/camera.h"
#include "common/status.h"

namespace loci {

class FrameUndistorter {
 public:
  FrameUndistorter(const PinholeCamera& camera, const LensDistortion& distortion);

  bool identity() const { return map_u_.empty(); }

  // Undistorts in place. Either pointer may be null. InvalidArgument when an image is not the
  // camera's size (nothing is changed then).
  Status Apply(cv::Mat* bgr, cv::Mat* depth) const;

 private:
  PinholeCamera camera_;
  // Raw-image pixel of each output pixel, CV_32FC1 (float maps: nearest-neighbour lookups round,
  // where fixed-point maps would truncate by up to a pixel).
  cv::Mat map_u_, map_v_;
};

}  // namespace loci
