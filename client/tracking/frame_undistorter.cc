#include "client/tracking/frame_undistorter.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>

namespace loci {
namespace {

cv::Mat CvK(const PinholeCamera& c) {
  cv::Mat K;
  cv::eigen2cv(c.K(), K);
  return K;
}

Status CheckSize(const cv::Mat* image, const PinholeCamera& c, const char* what) {
  if (image == nullptr || image->empty() ||
      (image->cols == c.width_px && image->rows == c.height_px)) {
    return absl::OkStatus();
  }
  return absl::InvalidArgumentError(absl::StrCat(what, " image is ", image->cols, "x", image->rows,
                                                 ", the camera's ", c.width_px, "x",
                                                 c.height_px));
}

}  // namespace

FrameUndistorter::FrameUndistorter(const PinholeCamera& camera, const LensDistortion& d)
    : camera_(camera) {
  if (d.IsZero()) return;
  const cv::Mat coeffs = (cv::Mat_<double>(1, 5) << d.k1, d.k2, d.p1, d.p2, d.k3);
  const cv::Mat K = CvK(camera);
  cv::initUndistortRectifyMap(K, coeffs, cv::Mat(), K,
                              cv::Size(camera.width_px, camera.height_px), CV_32FC1, map_u_,
                              map_v_);
}

Status FrameUndistorter::Apply(cv::Mat* bgr, cv::Mat* depth) const {
  LOCI_RETURN_IF_ERROR(CheckSize(bgr, camera_, "colour"));
  LOCI_RETURN_IF_ERROR(CheckSize(depth, camera_, "depth"));
  if (identity()) return absl::OkStatus();
  if (bgr != nullptr && !bgr->empty()) {
    cv::Mat out;
    cv::remap(*bgr, out, map_u_, map_v_, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    *bgr = out;
  }
  if (depth != nullptr && !depth->empty()) {
    cv::Mat out;
    cv::remap(*depth, out, map_u_, map_v_, cv::INTER_NEAREST, cv::BORDER_CONSTANT,
              cv::Scalar(0));
    *depth = out;
  }
  return absl::OkStatus();
}

}  // namespace loci
