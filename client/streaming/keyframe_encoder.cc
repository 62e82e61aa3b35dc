#include "client/streaming/keyframe_encoder.h"

#include "common/image_codec.h"
#include "proto/convert.h"

namespace loci {

StatusOr<v1::Keyframe> EncodeKeyframe(const KeyframeData& kf, int64_t seq, int jpeg_quality) {
  if (!IsFinite(kf.T_odom_cam)) return absl::InvalidArgumentError("keyframe pose is not finite");
  v1::Keyframe out;
  out.set_seq(seq);
  out.set_t_ns(kf.t_ns);
  ToProto(kf.T_odom_cam, out.mutable_t_odom_cam());
  LOCI_ASSIGN_OR_RETURN(*out.mutable_rgb_jpeg(), EncodeJpeg(kf.bgr, jpeg_quality));
  LOCI_ASSIGN_OR_RETURN(*out.mutable_depth_png(), EncodeDepthPng(kf.depth_u16));
  if (kf.gravity_cam) {
    out.set_has_gravity(true);
    ToProto(*kf.gravity_cam, out.mutable_gravity_cam());
  }
  out.set_segment(kf.segment);
  out.set_tracking_inliers(kf.tracking_inliers);
  for (const Detection2D& d : kf.detections) {
    LOCI_RETURN_IF_ERROR(ToProto(d, out.add_detections()));
  }
  return out;
}

}  // namespace loci
