// A tiny ray-cast world for server tests: a floor (z = 0, world z up) and axis-aligned boxes
// with known class and id, rendered exactly into depth, colour and per-box detections with masks.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "common/camera.h"
#include "common/detections_io.h"
#include "common/se3.h"

namespace loci::server::testing {

struct WorldBox {
  int64_t id = 0;  // also the detection's track id
  std::string class_name;
  Eigen::Vector3d min_m, max_m;  // world AABB
  cv::Vec3b bgr{0, 0, 255};
};

struct RenderedView {
  cv::Mat bgr;                          // CV_8UC3
  cv::Mat depth_u16;                    // CV_16UC1, 5000 per metre
  cv::Mat depth_m;                      // CV_32FC1
  std::vector<Detection2D> detections;  // one per visible box (>= 50 px), mask + track id
};

// Renders the world seen from T_world_cam (cam: x right, y down, z forward).
RenderedView Render(const std::vector<WorldBox>& boxes, const PinholeCamera& camera,
                    const SE3d& T_world_cam, bool with_masks = true);

// A camera at `eye` looking at `target` with world z up.
SE3d LookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target);

// `n` cameras on an arc around the default boxes (1.4 m out, 0.9 m up, 12 deg apart from
// -120 deg azimuth), each looking at them.
std::vector<SE3d> ArcPoses(int n);

// Three boxes on the floor, 0.4-0.6 m apart, plus optionally a person-sized box.
std::vector<WorldBox> DefaultBoxes(bool with_person);

}  // namespace loci::server::testing
