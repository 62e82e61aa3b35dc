#include "tests/server/box_world.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

namespace loci::server::testing {
namespace {

// Ray/AABB slab intersection; distance along the ray or +inf.
double HitBox(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const WorldBox& b) {
  double t0 = 0, t1 = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 3; ++i) {
    if (std::abs(d[i]) < 1e-12) {
      if (o[i] < b.min_m[i] || o[i] > b.max_m[i]) return std::numeric_limits<double>::infinity();
      continue;
    }
    double a = (b.min_m[i] - o[i]) / d[i], c = (b.max_m[i] - o[i]) / d[i];
    if (a > c) std::swap(a, c);
    t0 = std::max(t0, a);
    t1 = std::min(t1, c);
    if (t0 > t1) return std::numeric_limits<double>::infinity();
  }
  return t0 > 1e-6 ? t0 : std::numeric_limits<double>::infinity();
}

}  // namespace

SE3d LookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target) {
  const Eigen::Vector3d z = (target - eye).normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d y = z.cross(x);
  SE3d T = SE3d::Identity();
  T.linear().col(0) = x;
  T.linear().col(1) = y;
  T.linear().col(2) = z;
  T.translation() = eye;
  return T;
}

std::vector<SE3d> ArcPoses(int n) {
  std::vector<SE3d> poses;
  const Eigen::Vector3d target(0.1, 0.05, 0.05);
  for (int i = 0; i < n; ++i) {
    const double az = (-120.0 + 12.0 * i) * M_PI / 180.0;
    poses.push_back(
        LookAt(target + Eigen::Vector3d(1.4 * std::cos(az), 1.4 * std::sin(az), 0.9), target));
  }
  return poses;
}

std::vector<WorldBox> DefaultBoxes(bool with_person) {
  std::vector<WorldBox> boxes = {
      {1, "book", {-0.45, 0.0, 0.0}, {-0.25, 0.15, 0.06}, {40, 200, 40}},
      {2, "cup", {0.0, 0.0, 0.0}, {0.08, 0.08, 0.12}, {200, 40, 40}},
      {3, "laptop", {0.35, -0.05, 0.0}, {0.70, 0.20, 0.03}, {90, 90, 90}},
  };
  if (with_person) boxes.push_back({4, "person", {-0.1, 0.6, 0.0}, {0.3, 0.8, 1.7}, {0, 0, 250}});
  return boxes;
}

RenderedView Render(const std::vector<WorldBox>& boxes, const PinholeCamera& cam,
                    const SE3d& T_world_cam, bool with_masks) {
  RenderedView view;
  view.bgr = cv::Mat(cam.height_px, cam.width_px, CV_8UC3);
  view.depth_m = cv::Mat::zeros(cam.height_px, cam.width_px, CV_32FC1);
  cv::Mat ids = cv::Mat::zeros(cam.height_px, cam.width_px, CV_32SC1);
  const Eigen::Vector3d o = T_world_cam.translation();
  const Eigen::Matrix3d R = T_world_cam.rotation();
  for (int v = 0; v < cam.height_px; ++v) {
    for (int u = 0; u < cam.width_px; ++u) {
      const Eigen::Vector3d ray_cam((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0);
      const Eigen::Vector3d d = R * ray_cam;
      double best = std::numeric_limits<double>::infinity();
      int hit = 0;
      cv::Vec3b color(0, 0, 0);
      if (d.z() < -1e-9) {  // floor, checkerboard texture
        best = -o.z() / d.z();
        const Eigen::Vector3d p = o + best * d;
        const bool dark = (static_cast<int>(std::floor(p.x() / 0.2)) +
                           static_cast<int>(std::floor(p.y() / 0.2))) %
                          2;
        color = dark ? cv::Vec3b(60, 80, 100) : cv::Vec3b(160, 170, 180);
      }
      for (size_t i = 0; i < boxes.size(); ++i) {
        const double t = HitBox(o, d, boxes[i]);
        if (t < best) {
          best = t;
          hit = static_cast<int>(i) + 1;
          color = boxes[i].bgr;
        }
      }
      const double z_cam = best;  // ray_cam has unit z, so t is the depth
      if (std::isfinite(z_cam) && z_cam < 8.0) {
        view.depth_m.at<float>(v, u) = static_cast<float>(z_cam);
        view.bgr.at<cv::Vec3b>(v, u) = color;
        ids.at<int>(v, u) = hit;
      } else {
        view.bgr.at<cv::Vec3b>(v, u) = cv::Vec3b(30, 30, 30);
      }
    }
  }
  view.depth_m.convertTo(view.depth_u16, CV_16UC1, 5000.0);
  view.depth_u16.convertTo(view.depth_m, CV_32FC1, 1.0 / 5000.0);  // what the server decodes
  for (size_t i = 0; i < boxes.size(); ++i) {
    const cv::Mat m = ids == static_cast<int>(i) + 1;
    if (cv::countNonZero(m) < 50) continue;
    const cv::Rect r = cv::boundingRect(m);
    Detection2D det;
    det.class_name = boxes[i].class_name;
    det.class_id = 0;
    det.score = 0.9f;
    det.box_px = cv::Rect2f(r);
    det.track_id = boxes[i].id;
    if (with_masks) det.mask = m(MaskRect(det.box_px, cam.width_px, cam.height_px)).clone();
    view.detections.push_back(det);
  }
  return view;
}

}  // namespace loci::server::testing
