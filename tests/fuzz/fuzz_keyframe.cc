// libFuzzer target: the keyframe validator as the server runs it on a streamed message. Arbitrary
// bytes are parsed as loci.v1.Keyframe (as StreamKeyframes does), validated against a session
// with the TUM fr1 camera (640 x 480 px, depth 5000 per metre) by ValidateKeyframe, and a
// keyframe that passes is decoded again from its record by DecodeKeyframe (the replay path).
// Besides crashes and sanitizer reports, a broken contract aborts:
//   - a refusal is INVALID_ARGUMENT with a message and leaves the mapper input untouched;
//   - an accepted keyframe has images of its camera's size, finite depth >= 0 (m), a finite pose
//     inside the map extent, valid intrinsics, detections as checked;
//   - DecodeKeyframe of the accepted record succeeds and gives the same pixels.
// LOCI_FUZZ_VERBOSE=1 prints each verdict (to check that the seeds pass).
#include <google/protobuf/stubs/logging.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <opencv2/core.hpp>

#include "loci/v1/mapping.pb.h"
#include "server/runtime/keyframe_decoder.h"

namespace {

using loci::server::MapperKeyframe;

void Check(bool ok, const char* what) {
  if (ok) return;
  std::fprintf(stderr, "fuzz_keyframe: contract broken: %s\n", what);
  std::abort();
}

bool SameMat(const cv::Mat& a, const cv::Mat& b) {
  return a.type() == b.type() && a.size() == b.size() &&
         (a.empty() || cv::norm(a, b, cv::NORM_INF) == 0);
}

const loci::server::SessionRecord& Session() {
  static const loci::server::SessionRecord* session = [] {
    auto* s = new loci::server::SessionRecord();
    s->row_id = 1;
    s->session_id = "fuzz-1";
    s->robot_name = "fuzz";
    s->camera = loci::PinholeCamera::TumFr1();
    s->depth_scale = 5000.0;
    return s;
  }();
  return *session;
}

void CheckAccepted(const loci::server::KeyframeRecord& rec, const MapperKeyframe& kf,
                   const loci::server::ValidationLimits& limits) {
  const loci::PinholeCamera& c = rec.camera;
  Check(c.Validate().ok(), "accepted intrinsics are valid");
  Check(kf.bgr.type() == CV_8UC3 && kf.bgr.cols == c.width_px && kf.bgr.rows == c.height_px,
        "colour image is CV_8UC3 of the camera's size");
  Check(kf.depth_m.type() == CV_32FC1 && kf.depth_m.size() == kf.bgr.size(),
        "depth image is CV_32FC1 of the camera's size");
  // Finite and in [0, max): NaN and infinities fail checkRange.
  const bool depth_ok =
      cv::checkRange(kf.depth_m, true, nullptr, 0.0, std::numeric_limits<double>::max());
  Check(depth_ok, "depth is finite and >= 0 m");
  const Eigen::Vector3d t = kf.T_base_kf.translation();
  Check(t.allFinite() && t.cwiseAbs().maxCoeff() <= limits.map_extent_m,
        "pose is finite and inside the map extent");
  Check(kf.T_base_kf.rotation().allFinite(), "rotation is finite");
  Check(kf.detections.size() == rec.detections.size(), "every detection is kept");
  for (const loci::Detection2D& d : kf.detections) {
    Check(!d.class_name.empty() && d.score >= 0.f && d.score <= 1.f, "detection fields");
    Check(d.box_px.width > 0 && d.box_px.height > 0, "box has a positive size");
    Check(d.mask.empty() || d.mask.type() == CV_8UC1, "mask is CV_8UC1");
  }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  google::protobuf::SetLogHandler(nullptr);  // proto3 UTF-8 complaints on every bad string field
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  loci::v1::Keyframe kf;
  if (!kf.ParseFromArray(data, static_cast<int>(size))) return 0;
  const loci::server::ValidationLimits limits;
  MapperKeyframe decoded;
  auto rec = loci::server::ValidateKeyframe(kf, Session(), limits, &decoded);
  static const bool verbose = std::getenv("LOCI_FUZZ_VERBOSE") != nullptr;  // to check seeds
  if (verbose) std::fprintf(stderr, "fuzz_keyframe: %s\n", rec.status().ToString().c_str());
  if (!rec.ok()) {
    Check(rec.status().code() == absl::StatusCode::kInvalidArgument, "refusal is INVALID_ARGUMENT");
    Check(!rec.status().message().empty(), "refusal names the problem");
    Check(decoded.bgr.empty() && decoded.depth_m.empty(), "refusal leaves the output untouched");
    return 0;
  }
  CheckAccepted(*rec, decoded, limits);
  auto replayed = loci::server::DecodeKeyframe(*rec, Session());
  Check(replayed.ok(), "an accepted keyframe decodes again from its record");
  Check(SameMat(replayed->bgr, decoded.bgr) && SameMat(replayed->depth_m, decoded.depth_m),
        "replay decodes the same pixels");
  Check(replayed->detections.size() == decoded.detections.size(), "replay keeps the detections");
  return 0;
}
