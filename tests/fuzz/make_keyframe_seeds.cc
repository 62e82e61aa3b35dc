// Writes the seed corpus of fuzz_keyframe: serialized loci.v1.Keyframe messages built from the
// shipped TUM fr1_rpy sample, downscaled 8x to 80 x 60 px so that each seed stays a few KB, plus
// edge cases (no intrinsics, a mask of the wrong size, a box half outside the image ...).
//
//   make_keyframe_seeds tests/data/tum_fr1_rpy_sample tests/fuzz/corpus/keyframe
//
// The detections are hand-placed boxes with elliptic masks (no detector runs here); the pose is
// the ground-truth pose nearest to the RGB stamp, gravity from the accelerometer (GravityInCamAt).
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/camera.h"
#include "common/image_codec.h"
#include "common/tum_io.h"
#include "loci/v1/mapping.pb.h"
#include "proto/convert.h"

namespace {

constexpr int kScale = 8;  // 640 x 480 -> 80 x 60 px

void Write(const std::filesystem::path& path, const loci::v1::Keyframe& kf) {
  std::ofstream(path, std::ios::binary) << kf.SerializeAsString();
  std::printf("%s: %zu bytes\n", path.c_str(), kf.ByteSizeLong());
}

const loci::SE3d& NearestPose(const loci::Trajectory& gt, int64_t t_ns) {
  size_t best = 0;
  for (size_t i = 1; i < gt.size(); ++i) {
    if (std::llabs(gt[i].t_ns - t_ns) < std::llabs(gt[best].t_ns - t_ns)) best = i;
  }
  return gt[best].T_world_cam;
}

// A detection of `w` x `h` px at (x, y) with an elliptic mask of the box's size.
loci::v1::Detection Box(const char* name, int class_id, float x, float y, int w, int h) {
  loci::Detection2D d;
  d.class_id = class_id;
  d.class_name = name;
  d.score = 0.8f;
  d.track_id = class_id + 1;
  d.box_px = cv::Rect2f(x, y, static_cast<float>(w), static_cast<float>(h));
  d.mask = cv::Mat::zeros(h, w, CV_8UC1);
  cv::ellipse(d.mask, cv::Point(w / 2, h / 2), cv::Size(w / 2, h / 2), 0, 0, 360, 255, -1);
  loci::v1::Detection out;
  if (!loci::ToProto(d, &out).ok()) std::abort();
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s TUM_DIR OUT_DIR\n", argv[0]);
    return 2;
  }
  auto seq = loci::LoadTumSequence(argv[1]);
  if (!seq.ok() || seq->frames.size() < 3 || seq->groundtruth.empty()) {
    std::fprintf(stderr, "cannot load a TUM sequence with ground truth from %s\n", argv[1]);
    return 1;
  }
  const std::filesystem::path out = argv[2];
  std::filesystem::create_directories(out);
  const loci::PinholeCamera fr1 = loci::PinholeCamera::TumFr1();
  const size_t picks[] = {0, seq->frames.size() / 2, seq->frames.size() - 1};
  loci::v1::Keyframe first;
  for (size_t n = 0; n < std::size(picks); ++n) {
    const loci::TumFrame& f = seq->frames[picks[n]];
    cv::Mat bgr = cv::imread(f.rgb_path, cv::IMREAD_COLOR);
    cv::Mat depth = cv::imread(f.depth_path, cv::IMREAD_UNCHANGED);
    if (bgr.empty() || depth.type() != CV_16UC1) return 1;
    cv::resize(bgr, bgr, bgr.size() / kScale, 0, 0, cv::INTER_AREA);
    cv::resize(depth, depth, depth.size() / kScale, 0, 0, cv::INTER_NEAREST);
    loci::v1::Keyframe kf;
    kf.set_session_id("fuzz-1");
    kf.set_seq(static_cast<int64_t>(n));
    kf.set_t_ns(f.rgb_t_ns);
    loci::ToProto(NearestPose(seq->groundtruth, f.rgb_t_ns), kf.mutable_t_odom_cam());
    loci::ToProto(loci::PinholeCamera{fr1.fx / kScale, fr1.fy / kScale, fr1.cx / kScale,
                                      fr1.cy / kScale, bgr.cols, bgr.rows},
                  kf.mutable_intrinsics());
    kf.set_rgb_jpeg(*loci::EncodeJpeg(bgr, 75));
    kf.set_depth_png(*loci::EncodeDepthPng(depth));
    if (auto g = loci::GravityInCamAt(seq->accel, f.rgb_t_ns); g.ok()) {
      kf.set_has_gravity(true);
      loci::ToProto(*g, kf.mutable_gravity_cam());
    }
    *kf.add_detections() = Box("cup", 41, 10.f, 20.5f, 12, 14);
    if (n == 1) *kf.add_detections() = Box("book", 73, 40.f, 8.f, 30, 20);
    if (n == 2) kf.set_depth_scale(5000.0), kf.set_segment(1);
    Write(out / ("tum_" + std::to_string(n) + "_80x60.pb"), kf);
    if (n == 0) first = kf;
  }
  // Edge cases, each one change from the first keyframe.
  loci::v1::Keyframe e = first;
  e.clear_intrinsics();  // the session's 640 x 480 camera: the 80 x 60 images are refused
  Write(out / "edge_session_intrinsics.pb", e);
  e = first;
  e.clear_detections();
  e.clear_has_gravity();
  e.clear_gravity_cam();
  Write(out / "edge_bare.pb", e);
  e = first;
  *e.mutable_detections(0) = Box("cup", 41, 10.f, 20.5f, 12, 14);
  *e.mutable_detections(0)->mutable_mask_png() = *Box("cup", 41, 0, 0, 20, 14).mutable_mask_png();
  Write(out / "edge_mask_size.pb", e);
  e = first;
  *e.add_detections() = Box("chair", 56, 70.f, 50.f, 16, 16);  // half outside 80 x 60
  Write(out / "edge_box_edge.pb", e);
  e = first;
  e.mutable_t_odom_cam()->set_qw(0.5);  // not a unit quaternion
  Write(out / "edge_pose.pb", e);
  Write(out / "edge_empty.pb", loci::v1::Keyframe());
  return 0;
}
