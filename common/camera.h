// Pinhole camera model, the lens distortion a sensor's raw images carry and its rolling shutter.
// Everything past the tracking client's frame input (odometry, detection, the streamed
// keyframes, the server) sees pinhole, global-shutter images: the client removes the distortion
// first (client/tracking/frame_undistorter.h), then the rolling shutter's shear
// (client/tracking/rolling_shutter.h).
// Pixel (u, v): u right, v down, (0,0) the top-left pixel centre. Depth in metres along +z_cam.
#pragma once

#include <optional>

#include <Eigen/Core>

#include "common/status.h"

namespace loci {

struct PinholeCamera {
  double fx = 0, fy = 0;  // focal lengths, px
  double cx = 0, cy = 0;  // principal point, px
  int width_px = 0, height_px = 0;

  // TUM RGB-D freiburg1/2/3 and the ROS default used for fr3 (TUM's published values).
  static PinholeCamera TumFr1() { return {517.3, 516.5, 318.6, 255.3, 640, 480}; }
  static PinholeCamera TumFr2() { return {520.9, 521.0, 325.1, 249.7, 640, 480}; }
  static PinholeCamera TumFr3() { return {535.4, 539.2, 320.1, 247.6, 640, 480}; }

  // Point in the cam frame (m) from pixel and depth (m).
  Eigen::Vector3d BackProject(double u, double v, double depth_m) const {
    return {(u - cx) * depth_m / fx, (v - cy) * depth_m / fy, depth_m};
  }
  // Pixel of a cam-frame point; nullopt behind the camera (z <= 1e-6).
  std::optional<Eigen::Vector2d> Project(const Eigen::Vector3d& p_cam) const {
    if (p_cam.z() <= 1e-6) return std::nullopt;
    return Eigen::Vector2d(fx * p_cam.x() / p_cam.z() + cx, fy * p_cam.y() / p_cam.z() + cy);
  }
  bool InImage(const Eigen::Vector2d& uv, double border_px = 0) const {
    return uv.x() >= border_px && uv.y() >= border_px && uv.x() < width_px - border_px &&
           uv.y() < height_px - border_px;
  }
  Eigen::Matrix3d K() const {
    Eigen::Matrix3d k;
    k << fx, 0, cx, 0, fy, cy, 0, 0, 1;
    return k;
  }
  // Positive finite focal lengths, principal point inside the image, size in (0, 8192].
  Status Validate() const;
};

// Radial-tangential lens distortion of raw images (OpenCV's model, ROS's plumb_bob):
// coefficients k1, k2, p1, p2, k3 on normalised image coordinates. All zero: pinhole images.
struct LensDistortion {
  double k1 = 0, k2 = 0, p1 = 0, p2 = 0, k3 = 0;

  // TUM's published calibration of the freiburg1 and freiburg2 Kinects' colour cameras (the
  // depth images are registered to them); freiburg3's images are published undistorted.
  static LensDistortion TumFr1() { return {0.2624, -0.9531, -0.0054, 0.0026, 1.1633}; }
  static LensDistortion TumFr2() { return {0.2312, -0.7849, -0.0033, -0.0001, 0.9172}; }

  bool IsZero() const { return k1 == 0 && k2 == 0 && p1 == 0 && p2 == 0 && k3 == 0; }
  // Finite coefficients, and a model that stays monotonic over the image (a point further from
  // the centre stays further out), else InvalidArgument.
  Status Validate(const PinholeCamera& camera) const;
};

// A rolling-shutter colour camera exposes its rows one after another, top to bottom: the time
// between two rows, microseconds (0: a global shutter). Measured for the Kinect v1 of TUM
// freiburg1 against fr1_rpy's motion capture: 50 us (a 24 ms
// readout of 480 rows). freiburg2 is the same Kinect model and readout mode; not measured.
constexpr double kKinectV1LineTimeUs = 50.0;

// What a sensor's configuration gives: the pinhole intrinsics, its lens distortion and the
// rolling shutter's line time.
struct CameraCalibration {
  PinholeCamera intrinsics;
  LensDistortion distortion;
  double line_time_us = 0.0;  // rolling shutter: time between rows, us (0 = global shutter)
};

}  // namespace loci
