// Records for map store tests: a keyframe with every field set (binary image bytes with an
// embedded zero, a detection with a mask) and a session.
#pragma once

#include <string>

#include "server/storage/map_store.h"

namespace loci::server {

inline KeyframeRecord MakeKeyframe(int64_t session_row, int64_t seq) {
  KeyframeRecord kf;
  kf.session_row = session_row;
  kf.seq = seq;
  kf.t_ns = 1'700'000'000'000'000'000 + seq * 33'000'000;
  kf.T_odom_cam =
      MakeSE3(Vec3d(0.1 * seq, -0.2, 1.5), Quatd(Eigen::AngleAxisd(0.3, Vec3d::UnitY())));
  kf.camera = PinholeCamera::TumFr1();
  kf.depth_scale = 5000;
  kf.has_gravity = true;
  kf.gravity_cam = Vec3d(0, 1, 0);
  kf.segment = 2;
  kf.tracking_inliers = 150 + static_cast<int>(seq);
  kf.rgb_jpeg = std::string("\xff\xd8 jpeg bytes \0 with a zero", 26);
  kf.depth_png = "png bytes";
  Detection2D d;
  d.class_id = 41;
  d.class_name = "cup";
  d.score = 0.8f;
  d.box_px = cv::Rect2f(10, 20, 30, 40);
  d.track_id = 5;
  d.mask = cv::Mat(40, 30, CV_8UC1, cv::Scalar(255));
  kf.detections.push_back(d);
  return kf;
}

inline SessionRecord MakeSession(const std::string& robot, bool aligned = true) {
  SessionRecord s;
  s.robot_name = robot;
  s.camera = PinholeCamera::TumFr1();
  s.aligned = aligned;
  return s;
}

}  // namespace loci::server
