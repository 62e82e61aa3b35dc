#include "tests/server/keyframe_proto.h"

#include <gtest/gtest.h>

#include "common/image_codec.h"
#include "proto/convert.h"

namespace loci::server::testing {

loci::v1::OpenSessionRequest OpenRequest(const std::string& robot, const PinholeCamera& c,
                                         bool resume) {
  loci::v1::OpenSessionRequest req;
  req.set_robot_name(robot);
  loci::ToProto(c, req.mutable_intrinsics());
  req.set_depth_scale(5000.0);
  req.set_client_version("server tests");
  req.set_resume(resume);
  return req;
}

loci::v1::Keyframe MakeKeyframeFromBytes(const std::string& session_id, int64_t seq, int64_t t_ns,
                                         const SE3d& T, std::string rgb_jpeg, std::string depth_png,
                                         const std::vector<Detection2D>& detections,
                                         std::optional<Eigen::Vector3d> gravity_cam) {
  loci::v1::Keyframe kf;
  kf.set_session_id(session_id);
  kf.set_seq(seq);
  kf.set_t_ns(t_ns);
  ToProto(T, kf.mutable_t_odom_cam());
  kf.set_rgb_jpeg(std::move(rgb_jpeg));
  kf.set_depth_png(std::move(depth_png));
  if (gravity_cam) {
    kf.set_has_gravity(true);
    ToProto(*gravity_cam, kf.mutable_gravity_cam());
  }
  for (const Detection2D& d : detections) {
    const Status st = ToProto(d, kf.add_detections());
    if (!st.ok()) ADD_FAILURE() << st;  // test inputs are well-formed masks
  }
  return kf;
}

loci::v1::Keyframe MakeKeyframe(const std::string& session_id, int64_t seq, int64_t t_ns,
                                const SE3d& T, const cv::Mat& bgr, const cv::Mat& depth_u16,
                                const std::vector<Detection2D>& detections,
                                std::optional<Eigen::Vector3d> gravity_cam) {
  return MakeKeyframeFromBytes(session_id, seq, t_ns, T, *EncodeJpeg(bgr, 95),
                               *EncodeDepthPng(depth_u16), detections, gravity_cam);
}

}  // namespace loci::server::testing
