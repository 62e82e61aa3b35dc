#include "server/map/product_codec.h"

#include "common/image_codec.h"
#include "loci/store/v1/map_state.pb.h"
#include "server/map/fused_object.h"  // PackRgb

namespace loci::server {
namespace {

template <typename PointT>
void SetRgb(uint32_t rgb, PointT* p) {
  p->r = static_cast<uint8_t>(rgb >> 16);
  p->g = static_cast<uint8_t>(rgb >> 8);
  p->b = static_cast<uint8_t>(rgb);
}

void EncodeObservation(const ObjectObservation& o, loci::store::v1::ObservationProduct* out) {
  out->set_detection_index(o.detection_index);
  out->set_class_name(o.class_name);
  out->set_score(o.score);
  out->set_track_id(o.track_id);
  out->mutable_xyz_kf()->Reserve(static_cast<int>(3 * o.cloud_kf.size()));
  for (const auto& p : o.cloud_kf) {
    out->add_xyz_kf(p.x);
    out->add_xyz_kf(p.y);
    out->add_xyz_kf(p.z);
    out->add_rgb(PackRgb(p.r, p.g, p.b));
  }
}

StatusOr<ObjectObservation> DecodeObservation(const loci::store::v1::ObservationProduct& in) {
  if (in.xyz_kf_size() != 3 * in.rgb_size()) {
    return absl::DataLossError("stored observation: xyz and rgb sizes differ");
  }
  ObjectObservation o;
  o.detection_index = in.detection_index();
  o.class_name = in.class_name();
  o.score = in.score();
  o.track_id = in.track_id();
  o.cloud_kf.resize(in.rgb_size());
  for (int i = 0; i < in.rgb_size(); ++i) {
    auto& p = o.cloud_kf[i];
    p.x = in.xyz_kf(3 * i);
    p.y = in.xyz_kf(3 * i + 1);
    p.z = in.xyz_kf(3 * i + 2);
    SetRgb(in.rgb(i), &p);
  }
  return o;
}

Status DecodeStaticCloud(const loci::store::v1::KeyframeProducts& in, KeyframeProducts* out) {
  const int n = in.static_rgb_size();
  if (in.static_xyz_kf_size() != 3 * n || in.static_label_size() != n) {
    return absl::DataLossError("stored products: static cloud sizes differ");
  }
  out->static_cloud_kf.resize(n);
  for (int i = 0; i < n; ++i) {
    auto& p = out->static_cloud_kf[i];
    p.x = in.static_xyz_kf(3 * i);
    p.y = in.static_xyz_kf(3 * i + 1);
    p.z = in.static_xyz_kf(3 * i + 2);
    SetRgb(in.static_rgb(i), &p);
    if (in.static_label(i) < 0 || in.static_label(i) > in.observations_size()) {
      return absl::DataLossError("stored products: a point's label names no observation");
    }
    p.label = static_cast<uint32_t>(in.static_label(i));
  }
  return absl::OkStatus();
}

Status DecodeVisibility(const loci::store::v1::KeyframeProducts& in, KeyframeProducts* out) {
  out->depth_stride = in.depth_stride();
  if (!in.depth_mm_png().empty()) {
    LOCI_ASSIGN_OR_RETURN(cv::Mat depth_mm, DecodeDepthPng(in.depth_mm_png()));
    depth_mm.convertTo(out->visibility_depth_m, CV_32FC1, 1e-3);
  }
  if (!in.detections_jsonl().empty()) {
    LOCI_ASSIGN_OR_RETURN(FrameDetections frame, DetectionsFromJsonLine(in.detections_jsonl()));
    out->detection_boxes = std::move(frame.detections);
  }
  return absl::OkStatus();
}

}  // namespace

std::string EncodeProducts(const KeyframeProducts& products, const std::string& fingerprint) {
  loci::store::v1::KeyframeProducts out;
  out.set_fingerprint(fingerprint);
  const int n = static_cast<int>(products.static_cloud_kf.size());
  out.mutable_static_xyz_kf()->Reserve(3 * n);
  out.mutable_static_rgb()->Reserve(n);
  out.mutable_static_label()->Reserve(n);
  for (const auto& p : products.static_cloud_kf) {
    out.add_static_xyz_kf(p.x);
    out.add_static_xyz_kf(p.y);
    out.add_static_xyz_kf(p.z);
    out.add_static_rgb(PackRgb(p.r, p.g, p.b));
    out.add_static_label(static_cast<int32_t>(p.label));
  }
  for (const ObjectObservation& o : products.observations) {
    EncodeObservation(o, out.add_observations());
  }
  out.set_excluded_pixels(products.excluded_pixels);
  out.set_depth_stride(products.depth_stride);
  if (!products.visibility_depth_m.empty()) {
    cv::Mat depth_mm;
    products.visibility_depth_m.convertTo(depth_mm, CV_16UC1, 1000.0);
    if (auto png = EncodeDepthPng(depth_mm); png.ok()) out.set_depth_mm_png(std::move(*png));
  }
  FrameDetections frame;
  frame.detections = products.detection_boxes;
  out.set_detections_jsonl(DetectionsToJsonLine(frame));
  return out.SerializeAsString();
}

StatusOr<KeyframeProducts> DecodeProducts(const std::string& bytes,
                                          const std::string& fingerprint, bool with_visibility) {
  loci::store::v1::KeyframeProducts in;
  if (!in.ParseFromString(bytes)) return absl::DataLossError("stored products do not parse");
  if (in.fingerprint() != fingerprint) {
    return absl::FailedPreconditionError(absl::StrCat(
        "stored products were made with options ", in.fingerprint(), ", not ", fingerprint));
  }
  KeyframeProducts out;
  for (const auto& o : in.observations()) {
    LOCI_ASSIGN_OR_RETURN(ObjectObservation obs, DecodeObservation(o));
    out.observations.push_back(std::move(obs));
  }
  LOCI_RETURN_IF_ERROR(DecodeStaticCloud(in, &out));
  out.excluded_pixels = in.excluded_pixels();
  if (with_visibility) LOCI_RETURN_IF_ERROR(DecodeVisibility(in, &out));
  return out;
}

}  // namespace loci::server
