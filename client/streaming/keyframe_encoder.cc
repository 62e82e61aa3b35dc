#include "client/streaming/keyframe_encoder.h"

#include "common/image_codec.h"

namespace loci {

StatusOr<v1::Keyframe> EncodeKeyframe(const KeyframeData& kf, int64_t seq, int jpeg_quality) {
  if (!IsFinite(kf.T_odom_cam)) return absl::InvalidArgumentError("keyframe pose is not finite");
  v1::Keyframe out;
  out.set_seq(seq);
  out.set_t_ns(kf.t_ns);
  auto* pose = out.mutable_t_odom_cam();
  pose->mutable_t_m()->set_x(kf.T_odom_cam.translation().x());
  pose->mutable_t_m()->set_y(kf.T_odom_cam.translation().y());
  pose->mutable_t_m()->set_z(kf.T_odom_cam.translation().z());
  const Quatd q = QuatOf(kf.T_odom_cam);
  pose->set_qw(q.w());
  pose->set_qx(q.x());
  pose->set_qy(q.y());
  pose->set_qz(q.z());
  LOCI_ASSIGN_OR_RETURN(*out.mutable_rgb_jpeg(), EncodeJpeg(kf.bgr, jpeg_quality));
  LOCI_ASSIGN_OR_RETURN(*out.mutable_depth_png(), EncodeDepthPng(kf.depth_u16));
  if (kf.gravity_cam) {
    out.set_has_gravity(true);
    out.mutable_gravity_cam()->set_x(kf.gravity_cam->x());
    out.mutable_gravity_cam()->set_y(kf.gravity_cam->y());
    out.mutable_gravity_cam()->set_z(kf.gravity_cam->z());
  }
  out.set_segment(kf.segment);
  for (const Detection2D& d : kf.detections) {
    auto* o = out.add_detections();
    o->set_class_id(d.class_id);
    o->set_class_name(d.class_name);
    o->set_score(d.score);
    o->mutable_box()->set_x(d.box_px.x);
    o->mutable_box()->set_y(d.box_px.y);
    o->mutable_box()->set_width(d.box_px.width);
    o->mutable_box()->set_height(d.box_px.height);
    o->set_track_id(d.track_id);
    if (!d.mask.empty()) {
      LOCI_ASSIGN_OR_RETURN(*o->mutable_mask_png(), EncodeMaskPng(d.mask));
    }
  }
  return out;
}

}  // namespace loci
