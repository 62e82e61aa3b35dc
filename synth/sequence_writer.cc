#include "synth/sequence_writer.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <thread>

#include "absl/strings/str_join.h"
#include "common/detections_io.h"
#include "common/image_codec.h"
#include "common/objects_json.h"
#include "common/time.h"
#include "synth/annotate.h"
#include "synth/detector_noise.h"
#include "synth/renderer.h"

namespace loci::synth {
namespace fs = std::filesystem;
namespace {

constexpr double kGravityMps2 = 9.81;

Status WriteText(const std::string& path, const std::string& text) {
  return WriteFileBytes(path, text);
}

std::string ListFile(const char* what, const char* folder, const char* ext,
                     const std::vector<int64_t>& stamps, uint64_t seed) {
  std::string s =
      absl::StrCat("# ", what, "\n# loci synth, seed ", seed, "\n# timestamp filename\n");
  for (int64_t t : stamps) {
    const std::string stamp = FormatNsAsSeconds(t);
    absl::StrAppend(&s, stamp, " ", folder, "/", stamp, ext, "\n");
  }
  return s;
}

std::string CameraYaml(const Scene& s) {
  const PinholeCamera& c = s.camera;
  char buf[512];
  std::snprintf(buf, sizeof(buf),
                "# Intrinsics of this synthetic sequence (TUM fr1 scaled to the image size),\n"
                "# pixels; one pinhole model for RGB and depth. Depth PNG: depth_scale units per "
                "metre.\ncamera:\n  fx: %.6f\n  fy: %.6f\n  cx: %.6f\n  cy: %.6f\n  width: %d\n"
                "  height: %d\n  distortion: [0, 0, 0, 0, 0]  # rendered: no lens distortion\n"
                "depth_scale: %.1f\n",
                c.fx, c.fy, c.cx, c.cy, c.width_px, c.height_px, s.options.depth_scale);
  return buf;
}

std::string OptionsYaml(const SceneOptions& o) {
  return absl::StrCat("# Options of `loci synth` that produced this folder.\nseed: ", o.seed,
                      "\nframes: ", o.num_frames, "\nobjects: ", o.num_objects,
                      "\ndynamic: ", o.dynamic ? "true" : "false",
                      "\nnoise: ", o.depth_noise ? "true" : "false",
                      "\nvaried_layout: ", o.varied_layout ? "true" : "false",
                      "\ndetector_noise: ", o.detector_noise ? "true" : "false", "\nwidth: ", o.width_px,
                      "\nheight: ", o.height_px, "\nfps_hz: ", o.fps_hz,
                      "\naccel_with_motion: ", o.accel_with_motion ? "true" : "false",
                      "\nstart_t_ns: ", o.start_t_ns, "\nabsent: [", absl::StrJoin(o.absent_ids, ", "),
                      "]\nmoved: [", absl::StrJoin(o.moved_ids, ", "), "]\n");
}

// An object a perfect detector boxes in fewer than kSeenFrames frames (a third of a second), or
// in fewer than a tenth of a short sequence's frames, is "low" in objects.json: evaluation
// neither rewards nor penalises mapping what the camera barely saw.
constexpr int kSeenFrames = 10;

void MarkRarelySeen(const std::vector<FrameDetections>& exact, GroundTruthScene* objects) {
  const int seen_frames = std::min<int>(kSeenFrames, static_cast<int>(exact.size()) / 10);
  std::map<int64_t, int> frames;
  for (const FrameDetections& f : exact) {
    for (const Detection2D& d : f.detections) ++frames[d.track_id];
  }
  for (GroundTruthObject& g : objects->objects) {
    if (frames[g.id] < seen_frames) g.confidence = "low";
  }
}

Status WriteAccelerometer(const std::string& path, const std::vector<AccelSample>& samples) {
  std::string s = "# accelerometer data\n# loci synth (Kinect axes, m/s^2)\n# timestamp ax ay az\n";
  char buf[128];
  for (const AccelSample& a : samples) {
    std::snprintf(buf, sizeof(buf), "%s %.6f %.6f %.6f\n", FormatNsAsSeconds(a.t_ns).c_str(),
                  a.accel_mps2.x(), a.accel_mps2.y(), a.accel_mps2.z());
    s += buf;
  }
  return WriteText(path, s);
}

// Renders and writes frame i; returns its detections.
StatusOr<FrameDetections> WriteFrame(const Scene& scene, int i, const std::string& dir) {
  const int64_t t_ns = FrameStampNs(scene.options, i);
  const RenderedFrame f = Render(scene, CameraPoseAt(scene, t_ns), scene.camera, t_ns, 1);
  const std::string stamp = FormatNsAsSeconds(t_ns);
  LOCI_ASSIGN_OR_RETURN(const std::string jpg, EncodeJpeg(f.bgr, scene.options.jpeg_quality));
  LOCI_ASSIGN_OR_RETURN(const std::string png, EncodeDepthPng(f.depth_u16));
  LOCI_RETURN_IF_ERROR(WriteFileBytes(absl::StrCat(dir, "/rgb/", stamp, ".jpg"), jpg));
  LOCI_RETURN_IF_ERROR(WriteFileBytes(absl::StrCat(dir, "/depth/", stamp, ".png"), png));
  return FrameDetections{t_ns, DetectionsFromInstances(scene, f.instance_id)};
}

}  // namespace

std::vector<AccelSample> MakeAccelerometer(const Scene& scene) {
  const SceneOptions& o = scene.options;
  const int64_t t_end = FrameStampNs(o, o.num_frames - 1);
  std::vector<AccelSample> out;
  for (int k = 0;; ++k) {
    const int64_t t_ns = o.start_t_ns + std::llround(k * 1e6 / o.accel_rate_hz) * 1000;
    if (t_ns > t_end && k > 0) break;
    const double t_s = NsToSeconds(t_ns - o.start_t_ns);
    const Vec3d acc_world =
        o.accel_with_motion ? scene.camera_path.AccelerationAt(t_s) : Vec3d::Zero();
    const Vec3d f_cam = scene.camera_path.PoseAt(t_s).linear().transpose() *
                        (acc_world + Vec3d(0, 0, kGravityMps2));
    out.push_back({t_ns, Vec3d(-f_cam.x(), -f_cam.y(), f_cam.z())});
  }
  return out;
}

Status WriteSequence(const SceneOptions& options, const std::string& out_dir,
                     SequenceStats* stats) {
  const auto start = std::chrono::steady_clock::now();
  LOCI_ASSIGN_OR_RETURN(const Scene scene, MakeScene(options));
  std::error_code ec;
  for (const char* sub : {"rgb", "depth"}) {
    fs::create_directories(fs::path(out_dir) / sub, ec);
    if (ec) {
      return absl::PermissionDeniedError(
          absl::StrCat("cannot create ", out_dir, "/", sub, ": ", ec.message()));
    }
  }

  const int n = options.num_frames;
  std::vector<FrameDetections> detections(n);
  std::atomic<int> next{0};
  std::mutex error_mu;
  Status error = absl::OkStatus();
  auto worker = [&] {
    for (int i = next++; i < n; i = next++) {
      auto r = WriteFrame(scene, i, out_dir);
      if (!r.ok()) {
        std::lock_guard<std::mutex> lock(error_mu);
        if (error.ok()) error = r.status();
        next = n;  // stop the others early
        return;
      }
      detections[i] = std::move(*r);
    }
  };
  int threads = options.num_threads > 0 ? options.num_threads
                                        : static_cast<int>(std::thread::hardware_concurrency());
  threads = std::clamp(threads, 1, n);
  std::vector<std::thread> pool;
  for (int k = 0; k < threads; ++k) pool.emplace_back(worker);
  for (std::thread& t : pool) t.join();
  LOCI_RETURN_IF_ERROR(error);

  std::vector<int64_t> stamps(n);
  Trajectory gt(n);
  for (int i = 0; i < n; ++i) {
    stamps[i] = FrameStampNs(options, i);
    gt[i] = {stamps[i], CameraPoseAt(scene, stamps[i])};
  }
  const std::string d = out_dir + "/";
  LOCI_RETURN_IF_ERROR(
      WriteText(d + "rgb.txt", ListFile("color images", "rgb", ".jpg", stamps, options.seed)));
  LOCI_RETURN_IF_ERROR(
      WriteText(d + "depth.txt", ListFile("depth maps", "depth", ".png", stamps, options.seed)));
  LOCI_RETURN_IF_ERROR(WriteTumTrajectory(d + "groundtruth.txt", gt));
  LOCI_RETURN_IF_ERROR(WriteAccelerometer(d + "accelerometer.txt", MakeAccelerometer(scene)));
  LOCI_RETURN_IF_ERROR(WriteText(d + "camera.yaml", CameraYaml(scene)));
  LOCI_RETURN_IF_ERROR(WriteText(d + "synth.yaml", OptionsYaml(options)));
  GroundTruthScene objects = ToGroundTruth(scene);
  MarkRarelySeen(detections, &objects);
  LOCI_RETURN_IF_ERROR(WriteObjectsJson(d + "objects.json", objects));
  if (options.detector_noise) {
    ApplyDetectorNoise(DetectorNoise{}, options.seed, options.width_px, options.height_px,
                       &detections);
  }
  LOCI_RETURN_IF_ERROR(WriteDetectionsJsonl(d + "detections.jsonl", detections));

  if (stats) {
    stats->frames = n;
    stats->objects = static_cast<int>(objects.objects.size());
    stats->detections = 0;
    for (const FrameDetections& f : detections) stats->detections += f.detections.size();
    stats->seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  return absl::OkStatus();
}

}  // namespace loci::synth
