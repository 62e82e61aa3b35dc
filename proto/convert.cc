#include "proto/convert.h"

#include "common/image_codec.h"

namespace loci {

void ToProto(const SE3d& T_a_b, v1::Pose* out) {
  ToProto(Eigen::Vector3d(T_a_b.translation()), out->mutable_t_m());
  const Quatd q = QuatOf(T_a_b);
  out->set_qw(q.w());
  out->set_qx(q.x());
  out->set_qy(q.y());
  out->set_qz(q.z());
}

SE3d PoseFromProto(const v1::Pose& p) {
  return MakeSE3(Vec3d(p.t_m().x(), p.t_m().y(), p.t_m().z()), Quatd(p.qw(), p.qx(), p.qy(), p.qz()));
}

void ToProto(const Eigen::Vector3d& v, v1::Vec3* out) {
  out->set_x(v.x());
  out->set_y(v.y());
  out->set_z(v.z());
}

void ToProto(const PinholeCamera& camera, v1::CameraIntrinsics* out) {
  out->set_fx(camera.fx);
  out->set_fy(camera.fy);
  out->set_cx(camera.cx);
  out->set_cy(camera.cy);
  out->set_width_px(camera.width_px);
  out->set_height_px(camera.height_px);
}

Status ToProto(const Detection2D& d, v1::Detection* out) {
  out->set_class_id(d.class_id);
  out->set_class_name(d.class_name);
  out->set_score(d.score);
  out->mutable_box()->set_x(d.box_px.x);
  out->mutable_box()->set_y(d.box_px.y);
  out->mutable_box()->set_width(d.box_px.width);
  out->mutable_box()->set_height(d.box_px.height);
  out->set_track_id(d.track_id);
  if (!d.mask.empty()) {
    LOCI_ASSIGN_OR_RETURN(*out->mutable_mask_png(), EncodeMaskPng(d.mask));
  }
  return absl::OkStatus();
}

}  // namespace loci
