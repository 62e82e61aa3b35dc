#include "server/runtime/keyframe_decoder.h"

#include <cmath>

#include "common/image_codec.h"
#include "common/time.h"

namespace loci::server {
namespace {

Status Invalid(const std::string& msg) { return absl::InvalidArgumentError(msg); }

StatusOr<Detection2D> ConvertDetection(const loci::v1::Detection& d, int index, int width,
                                       int height) {
  const std::string where = absl::StrCat("detection ", index, ": ");
  Detection2D out;
  out.class_id = d.class_id();
  out.class_name = d.class_name();
  out.score = d.score();
  out.track_id = d.track_id();
  if (out.class_name.empty() || out.class_name.size() > 64) {
    return Invalid(where + "class_name must have 1 to 64 characters");
  }
  if (!std::isfinite(out.score) || out.score < 0.f || out.score > 1.f) {
    return Invalid(absl::StrCat(where, "score ", out.score, " is not in [0, 1]"));
  }
  const auto& b = d.box();
  if (!std::isfinite(b.x()) || !std::isfinite(b.y()) || !std::isfinite(b.width()) ||
      !std::isfinite(b.height()) || b.width() <= 0 || b.height() <= 0) {
    return Invalid(where + "box must be finite with positive size");
  }
  out.box_px = cv::Rect2f(b.x(), b.y(), b.width(), b.height());
  const cv::Rect r = MaskRect(out.box_px, width, height);
  if (r.area() <= 0) return Invalid(where + "box lies outside the image");
  if (!d.mask_png().empty()) {
    auto mask = DecodeMaskPng(d.mask_png(), r.width + 1, r.height + 1);
    if (!mask.ok()) return Invalid(where + "mask: " + std::string(mask.status().message()));
    // Masks cover the box rounded outwards (docs/formats.md); allow one pixel of rounding slack.
    if (std::abs(mask->cols - r.width) > 1 || std::abs(mask->rows - r.height) > 1) {
      return Invalid(absl::StrCat(where, "mask is ", mask->cols, "x", mask->rows,
                                  " px but the box covers ", r.width, "x", r.height, " px"));
    }
    out.mask = *mask;
  }
  return out;
}

Status CheckStamp(int64_t t_ns, const ValidationLimits& limits) {
  if (t_ns < kMinKeyframeTNs) {
    return Invalid(absl::StrCat("t_ns ", t_ns, " is before 2000-01-01 (ns since the Unix epoch)"));
  }
  const int64_t now_ns = NowNs();
  if (t_ns > now_ns && t_ns - now_ns > limits.max_future_ns) {
    return Invalid(absl::StrCat("t_ns ", t_ns, " is ", (t_ns - now_ns) / kNsPerSecond,
                                " s in the future (limit ", limits.max_future_ns / kNsPerSecond,
                                " s)"));
  }
  return absl::OkStatus();
}

}  // namespace

StatusOr<KeyframeRecord> ValidateKeyframe(const loci::v1::Keyframe& kf,
                                          const SessionRecord& session,
                                          const ValidationLimits& limits, MapperKeyframe* decoded) {
  KeyframeRecord rec;
  rec.session_row = session.row_id;
  rec.seq = kf.seq();
  if (kf.seq() < 0) return Invalid(absl::StrCat("seq ", kf.seq(), " is negative"));
  LOCI_RETURN_IF_ERROR(CheckStamp(kf.t_ns(), limits));
  rec.t_ns = kf.t_ns();
  const auto& p = kf.t_odom_cam();
  if (!kf.has_t_odom_cam()) return Invalid("T_odom_cam is missing");
  const Vec3d t(p.t_m().x(), p.t_m().y(), p.t_m().z());
  if (Status s = ValidatePose(t, p.qw(), p.qx(), p.qy(), p.qz()); !s.ok()) {
    return Invalid(absl::StrCat("T_odom_cam: ", s.message()));
  }
  rec.T_odom_cam = MakeSE3(t, Quatd(p.qw(), p.qx(), p.qy(), p.qz()));
  const Vec3d t_base_kf = (session.T_base_odom * rec.T_odom_cam).translation();
  if (t_base_kf.cwiseAbs().maxCoeff() > limits.map_extent_m) {
    return Invalid(absl::StrCat("T_odom_cam: the keyframe lies at (", t_base_kf.x(), ", ",
                                t_base_kf.y(), ", ", t_base_kf.z(), ") m, outside the map extent of +-",
                                limits.map_extent_m, " m (server.map_extent_m)"));
  }

  rec.camera = session.camera;
  if (kf.has_intrinsics() && kf.intrinsics().fx() != 0) {
    const auto& k = kf.intrinsics();
    rec.camera = {k.fx(),
                  k.fy(),
                  k.cx(),
                  k.cy(),
                  static_cast<int>(k.width_px()),
                  static_cast<int>(k.height_px())};
  }
  if (rec.camera.width_px > limits.max_image_px || rec.camera.height_px > limits.max_image_px) {
    return Invalid(absl::StrCat("image size ", rec.camera.width_px, "x", rec.camera.height_px,
                                " exceeds ", limits.max_image_px, " px"));
  }
  if (Status s = rec.camera.Validate(); !s.ok()) {
    return Invalid(absl::StrCat("intrinsics: ", s.message()));
  }
  rec.depth_scale = kf.depth_scale() != 0 ? kf.depth_scale() : session.depth_scale;
  if (!std::isfinite(rec.depth_scale) || rec.depth_scale <= 0 || rec.depth_scale > 1e6) {
    return Invalid(absl::StrCat("depth_scale ", rec.depth_scale, " is not in (0, 1e6]"));
  }
  rec.has_gravity = kf.has_gravity();
  if (rec.has_gravity) {
    rec.gravity_cam = Vec3d(kf.gravity_cam().x(), kf.gravity_cam().y(), kf.gravity_cam().z());
    if (!rec.gravity_cam.allFinite() || std::abs(rec.gravity_cam.norm() - 1.0) > 0.05) {
      return Invalid("gravity_cam must be a finite unit vector");
    }
  }
  rec.segment = kf.segment();
  if (kf.tracking_inliers() < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("tracking_inliers must be >= 0 (0 = unknown), got ", kf.tracking_inliers()));
  }
  rec.tracking_inliers = kf.tracking_inliers();

  const int w = rec.camera.width_px, h = rec.camera.height_px;
  auto bgr = DecodeJpeg(kf.rgb_jpeg(), w, h);
  if (!bgr.ok()) return Invalid(absl::StrCat("rgb_jpeg: ", bgr.status().message()));
  auto depth = DecodeDepthPng(kf.depth_png(), w, h);
  if (!depth.ok()) return Invalid(absl::StrCat("depth_png: ", depth.status().message()));

  if (kf.detections_size() > limits.max_detections) {
    return Invalid(absl::StrCat(kf.detections_size(), " detections exceed the limit of ",
                                limits.max_detections));
  }
  for (int i = 0; i < kf.detections_size(); ++i) {
    LOCI_ASSIGN_OR_RETURN(Detection2D d, ConvertDetection(kf.detections(i), i, w, h));
    rec.detections.push_back(std::move(d));
  }
  rec.rgb_jpeg = kf.rgb_jpeg();
  rec.depth_png = kf.depth_png();

  if (decoded != nullptr) {
    decoded->session_row = session.row_id;
    decoded->robot = session.robot_name;
    decoded->t_ns = rec.t_ns;
    decoded->T_base_kf = session.T_base_odom * rec.T_odom_cam;
    decoded->T_odom_kf = rec.T_odom_cam;
    decoded->segment = rec.segment;
    decoded->tracking_inliers = rec.tracking_inliers;
    decoded->camera = rec.camera;
    decoded->bgr = std::move(*bgr);
    decoded->depth_m = DepthToMetres(*depth, rec.depth_scale);
    decoded->detections = rec.detections;
    decoded->has_gravity = rec.has_gravity;
    decoded->gravity_cam = rec.gravity_cam;
  }
  return rec;
}

MapperKeyframe KeyframeMeta(const KeyframeRecord& rec, const SessionRecord& session) {
  MapperKeyframe kf;
  kf.keyframe_id = rec.id;
  kf.session_row = session.row_id;
  kf.robot = session.robot_name;
  kf.t_ns = rec.t_ns;
  kf.T_base_kf = BaseFromKeyframe(rec, session);
  kf.T_odom_kf = rec.T_odom_cam;
  kf.segment = rec.segment;
  kf.tracking_inliers = rec.tracking_inliers;
  kf.camera = rec.camera;
  kf.has_gravity = rec.has_gravity;
  kf.gravity_cam = rec.gravity_cam;
  return kf;
}

StatusOr<StoredImages> DecodeStoredImages(const KeyframeRecord& rec) {
  StoredImages images;
  LOCI_ASSIGN_OR_RETURN(images.bgr,
                        DecodeJpeg(rec.rgb_jpeg, rec.camera.width_px, rec.camera.height_px));
  LOCI_ASSIGN_OR_RETURN(cv::Mat depth,
                        DecodeDepthPng(rec.depth_png, rec.camera.width_px, rec.camera.height_px));
  images.depth_m = DepthToMetres(depth, rec.depth_scale);
  return images;
}

StatusOr<MapperKeyframe> DecodeKeyframe(const KeyframeRecord& rec, const SessionRecord& session) {
  MapperKeyframe kf = KeyframeMeta(rec, session);
  LOCI_ASSIGN_OR_RETURN(StoredImages images, DecodeStoredImages(rec));
  kf.bgr = std::move(images.bgr);
  kf.depth_m = std::move(images.depth_m);
  kf.detections = rec.detections;
  return kf;
}

}  // namespace loci::server
