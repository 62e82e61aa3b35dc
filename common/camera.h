// Pinhole camera model (no distortion: TUM images are used as given, like the benchmark tools).
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

}  // namespace loci
