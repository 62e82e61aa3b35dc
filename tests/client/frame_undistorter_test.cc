// FrameUndistorter against OpenCV's forward lens model (cv::projectPoints): points drawn where a
// distorted lens images them come out where a pinhole images them, the depth image stays
// registered to the colour image, and bad sizes are refused.
#include "client/tracking/frame_undistorter.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

namespace loci {
namespace {

const PinholeCamera kCam = PinholeCamera::TumFr1();
const LensDistortion kLens = LensDistortion::TumFr1();

// Where the distorted lens images the pinhole pixel `uv` (OpenCV's forward model).
cv::Point2d Distort(const cv::Point2d& uv) {
  const std::vector<cv::Point3d> ray{{(uv.x - kCam.cx) / kCam.fx, (uv.y - kCam.cy) / kCam.fy, 1}};
  const cv::Mat K = (cv::Mat_<double>(3, 3) << kCam.fx, 0, kCam.cx, 0, kCam.fy, kCam.cy, 0, 0, 1);
  const cv::Mat D = (cv::Mat_<double>(1, 5) << kLens.k1, kLens.k2, kLens.p1, kLens.p2, kLens.k3);
  std::vector<cv::Point2d> out;
  cv::projectPoints(ray, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, D, out);
  return out[0];
}

// Intensity-weighted centroid of the blob around `near` (window of +-6 px).
cv::Point2d BlobCentroid(const cv::Mat& grey, const cv::Point2d& near) {
  double sum = 0, su = 0, sv = 0;
  for (int v = int(near.y) - 6; v <= int(near.y) + 6; ++v) {
    for (int u = int(near.x) - 6; u <= int(near.x) + 6; ++u) {
      const double w = grey.at<uchar>(v, u);
      sum += w, su += w * u, sv += w * v;
    }
  }
  return {su / sum, sv / sum};
}

TEST(FrameUndistorter, PointsMoveToWhereAPinholeImagesThem) {
  // Gaussian dots drawn at their distorted positions, over the whole image.
  cv::Mat raw(kCam.height_px, kCam.width_px, CV_8UC3, cv::Scalar::all(0));
  std::vector<cv::Point2d> pinhole;
  for (double v = 40; v <= 440; v += 50) {
    for (double u = 40; u <= 600; u += 56) pinhole.push_back({u, v});
  }
  double largest_shift_px = 0;
  for (const cv::Point2d& p : pinhole) {
    const cv::Point2d d = Distort(p);
    largest_shift_px = std::max(largest_shift_px, std::hypot(d.x - p.x, d.y - p.y));
    for (int v = int(d.y) - 5; v <= int(d.y) + 5; ++v) {
      for (int u = int(d.x) - 5; u <= int(d.x) + 5; ++u) {
        if (u < 0 || v < 0 || u >= raw.cols || v >= raw.rows) continue;
        const double g = 250 * std::exp(-(std::pow(u - d.x, 2) + std::pow(v - d.y, 2)) / 3.0);
        raw.at<cv::Vec3b>(v, u) = cv::Vec3b::all(static_cast<uchar>(g));
      }
    }
  }
  EXPECT_GT(largest_shift_px, 5.0);  // fr1's lens moves points by several pixels at the rim

  const FrameUndistorter undistort(kCam, kLens);
  ASSERT_FALSE(undistort.identity());
  cv::Mat bgr = raw.clone();
  ASSERT_TRUE(undistort.Apply(&bgr, nullptr).ok());
  cv::Mat grey;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  double worst_px = 0;
  for (const cv::Point2d& p : pinhole) {
    const cv::Point2d c = BlobCentroid(grey, p);
    worst_px = std::max(worst_px, std::hypot(c.x - p.x, c.y - p.y));
  }
  EXPECT_LT(worst_px, 0.3) << "a dot is " << worst_px << " px from its pinhole position";
}

TEST(FrameUndistorter, DepthStaysRegisteredToTheColourImage) {
  // Each raw depth pixel holds its own column + 1: after undistortion, output pixel p must hold
  // the column of the raw pixel the lens images p at (nearest), or 0 where that is outside.
  cv::Mat depth(kCam.height_px, kCam.width_px, CV_16UC1);
  for (int v = 0; v < depth.rows; ++v) {
    for (int u = 0; u < depth.cols; ++u) depth.at<uint16_t>(v, u) = static_cast<uint16_t>(u + 1);
  }
  const FrameUndistorter undistort(kCam, kLens);
  ASSERT_TRUE(undistort.Apply(nullptr, &depth).ok());
  int checked = 0, holes = 0;
  for (int v = 0; v < depth.rows; v += 7) {
    for (int u = 0; u < depth.cols; u += 7) {
      const cv::Point2d d = Distort({double(u), double(v)});
      const uint16_t got = depth.at<uint16_t>(v, u);
      if (d.x < -0.5 || d.y < -0.5 || d.x > depth.cols - 0.5 || d.y > depth.rows - 0.5) {
        EXPECT_EQ(got, 0) << "outside the raw image at (" << u << ", " << v << ")";
        ++holes;
        continue;
      }
      EXPECT_NEAR(got - 1, d.x, 0.51) << "at (" << u << ", " << v << ")";
      ++checked;
    }
  }
  EXPECT_GT(checked, 5000);
  EXPECT_GT(holes, 0);  // the corners of fr1's undistorted image lie outside the raw image
}

TEST(FrameUndistorter, ZeroDistortionLeavesImagesAndWrongSizesAreRefused) {
  const FrameUndistorter none(kCam, LensDistortion{});
  EXPECT_TRUE(none.identity());
  cv::Mat bgr(kCam.height_px, kCam.width_px, CV_8UC3, cv::Scalar(10, 20, 30));
  const cv::Mat before = bgr.clone();
  ASSERT_TRUE(none.Apply(&bgr, nullptr).ok());
  EXPECT_EQ(cv::norm(bgr, before, cv::NORM_INF), 0);

  const FrameUndistorter lens(kCam, kLens);
  cv::Mat small(240, 320, CV_8UC3, cv::Scalar::all(7));
  cv::Mat depth(kCam.height_px, kCam.width_px, CV_16UC1, cv::Scalar(1000));
  const cv::Mat depth_before = depth.clone();
  const Status s = lens.Apply(&small, &depth);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("320x240"), std::string::npos) << s;
  EXPECT_EQ(cv::norm(depth, depth_before, cv::NORM_INF), 0);  // nothing changed
  EXPECT_EQ(small.cols, 320);
}

}  // namespace
}  // namespace loci
