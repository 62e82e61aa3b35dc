// loci-track: the tracking client. Runs RGB-D odometry over a TUM folder (or takes poses from a
// trajectory file), selects keyframes, attaches detections and gravity, and streams keyframes to
// loci-server. See `loci-track --help`.
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <iostream>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "client/app/keyframe_stage.h"
#include "client/app/pose_source.h"
#include "client/streaming/map_client.h"
#include "client/tracking/tracker.h"
#include "common/config.h"
#include "common/detections_io.h"
#include "common/tum_io.h"
#include "detection/detection_config.h"
#include "detection/detector_options.h"

namespace loci {
namespace {

struct Args {
  std::string tum_dir, server = "127.0.0.1:50051", robot = "robot", config, trajectory, keyframes;
  std::string poses, detections, model;
  bool offline = false, no_progress = false;
  int max_frames = 0;
};

void Progress(size_t i, size_t n, int kfs, const FrameResult& r) {
  const int width = 30;
  const int filled = n ? static_cast<int>(width * (i + 1) / n) : width;
  std::fprintf(stderr, "\r[%s%s] %zu/%zu  kf %d  inliers %d  %.1f ms   ",
               std::string(filled, '#').c_str(), std::string(width - filled, '.').c_str(), i + 1, n,
               kfs, r.num_inliers, r.track_ms);
}

int Run(const Args& a) {
  TrackerOptions topt;
  MapClientOptions mopt;
  mopt.server = a.server;
  mopt.robot_name = a.robot;
  const std::string cfg = a.config.empty() ? SourceDir() + "/config/client.yaml" : a.config;
  if (auto node = LoadYamlFile(cfg); node.ok()) {
    if (Status s = topt.FromYaml((*node)["tracker"]); !s.ok()) {
      std::cerr << "error: " << cfg << ": " << s.message() << "\n";
      return 2;
    }
    (void)ReadOptional((*node)["streaming"], "max_unacked", &mopt.max_unacked);
    (void)ReadOptional((*node)["streaming"], "jpeg_quality", &mopt.jpeg_quality);
  } else if (!a.config.empty()) {
    std::cerr << "error: " << node.status().message() << "\n";
    return 2;
  }
  if (auto classes = LoadYamlFile(SourceDir() + "/config/classes.yaml"); classes.ok()) {
    (void)topt.ClassWeightsFromYaml(*classes);
  }
  auto seq = LoadTumSequence(a.tum_dir);
  if (!seq.ok()) {
    std::cerr << "error: " << seq.status().message() << "\n";
    return 2;
  }
  if (auto cam = LoadYamlFile(a.tum_dir + "/camera.yaml"); cam.ok()) {
    if (auto c = CameraFromYaml(*cam); c.ok()) topt.camera = *c;
  }

  // Detections: a file (also used by the odometry's dynamic prior), none, or a detector run on
  // keyframes in the keyframe stage's thread.
  std::vector<FrameDetections> file_dets;
  std::unique_ptr<detection::Detector> detector;
  std::unique_ptr<detection::MultiObjectTracker> mot;
  // config/detection.yaml: detector and tracker (no --detections), masks (any detections).
  std::optional<detection::DetectionConfig> dc;
  if (a.detections != "none") {
    auto c = detection::LoadDetectionConfig(detection::DefaultDetectionConfigPath());
    if (!c.ok()) {
      std::cerr << "error: " << c.status().message() << "\n";
      return 2;
    }
    dc = std::move(*c);
  }
  if (!a.detections.empty() && a.detections != "none") {
    auto d = ReadDetectionsJsonl(a.detections);
    if (!d.ok()) {
      std::cerr << "error: " << d.status().message() << "\n";
      return 2;
    }
    file_dets = std::move(*d);
  } else if (a.detections.empty()) {
    if (!a.model.empty()) dc->detector.model_path = a.model;
    auto det = detection::MakeDetector(dc->detector);
    if (!det.ok()) {
      std::cerr << "error: detector: " << det.status().message()
                << " (use --detections FILE or --detections none)\n";
      return 2;
    }
    detector = std::move(*det);
    mot = std::make_unique<detection::MultiObjectTracker>(dc->tracker);
  }
  const bool has_detector = detector != nullptr;
  constexpr int64_t kMaxBoxAgeNs = 300'000'000;

  std::unique_ptr<MapClient> client;
  if (!a.offline) {
    auto c = MapClient::Connect(mopt, topt.camera, topt.depth_scale);
    if (!c.ok()) {
      std::cerr << "error: " << a.server << ": " << c.status().message()
                << " (start loci-server or use --offline)\n";
      return 3;
    }
    client = std::move(*c);
  }
  // Object masks from box + depth go with the detections (config/detection.yaml `mask`).
  std::optional<KeyframeMasking> masking;
  if (dc) {
    masking = KeyframeMasking{dc->mask, topt.camera};
    masking->options.depth_scale = static_cast<float>(topt.depth_scale);
  }
  KeyframeStage stage(std::move(detector), std::move(mot),
                      client ? KeyframeStage::Sink([&](KeyframeData kf) {
                        return client->Send(std::move(kf)).status();
                      })
                             : KeyframeStage::Sink(),
                      4, masking);

  std::unique_ptr<Tracker> tracker;
  std::unique_ptr<PoseSource> pose_source;
  if (!a.poses.empty()) {
    auto p = PoseSource::FromFile(a.poses, topt.keyframes);
    if (!p.ok()) {
      std::cerr << "error: " << p.status().message() << "\n";
      return 2;
    }
    pose_source = std::move(*p);
  } else {
    auto t = Tracker::Create(topt);
    if (!t.ok()) {
      std::cerr << "error: " << t.status().message() << "\n";
      return 2;
    }
    tracker = std::move(*t);
  }

  Trajectory traj, kf_traj;
  const size_t n =
      a.max_frames > 0 ? std::min<size_t>(a.max_frames, seq->frames.size()) : seq->frames.size();
  int keyframes = 0, lost = 0;
  for (size_t i = 0; i < n; ++i) {
    const TumFrame& f = seq->frames[i];
    cv::Mat bgr = cv::imread(f.rgb_path, cv::IMREAD_COLOR);
    cv::Mat depth = cv::imread(f.depth_path, cv::IMREAD_UNCHANGED);
    if (bgr.empty() || depth.empty()) {
      spdlog::warn("frame {}: unreadable image, skipped", i);
      continue;
    }
    std::vector<Detection2D> dets;
    bool dets_from_keyframe = false;
    if (const FrameDetections* fd = FindDetections(file_dets, f.rgb_t_ns)) {
      dets = fd->detections;
    } else if (has_detector) {
      // The detector runs asynchronously on keyframes: its latest boxes (at most
      // kMaxBoxAgeNs old) serve as the dynamic prior; the geometric test still decides.
      FrameDetections latest = stage.LatestDetections();
      if (latest.t_ns > 0 && f.rgb_t_ns - latest.t_ns <= kMaxBoxAgeNs) {
        dets = std::move(latest.detections);
        dets_from_keyframe = true;
      }
    }
    StatusOr<FrameResult> r =
        tracker ? tracker->Track(bgr, depth, f.rgb_t_ns, &dets) : pose_source->At(f.rgb_t_ns);
    if (!r.ok()) {
      spdlog::warn("frame {}: {}", i, std::string(r.status().message()));
      continue;
    }
    if (!a.no_progress) Progress(i, n, keyframes, *r);
    if (!r->tracked) {
      ++lost;
      continue;
    }
    traj.push_back({f.rgb_t_ns, r->T_odom_cam});
    if (!r->keyframe) continue;
    ++keyframes;
    kf_traj.push_back({f.rgb_t_ns, r->T_odom_cam});
    KeyframeData kf;
    kf.t_ns = f.rgb_t_ns;
    kf.T_odom_cam = r->T_odom_cam;
    kf.bgr = bgr;
    kf.depth_u16 = depth;
    if (!dets_from_keyframe) kf.detections = std::move(dets);  // else: the detector fills them
    kf.segment = r->segment;
    if (auto g = GravityInCamAt(seq->accel, f.rgb_t_ns); g.ok()) kf.gravity_cam = *g;
    stage.Push(std::move(kf));
  }
  if (!a.no_progress) std::fprintf(stderr, "\n");
  Status stage_status = stage.Finish();
  int rc = 0;
  if (!a.trajectory.empty()) {
    if (Status s = WriteTumTrajectory(a.trajectory, traj); !s.ok()) {
      std::cerr << "error: " << s.message() << "\n";
      rc = 1;
    }
  }
  if (!a.keyframes.empty()) {
    if (Status s = WriteTumTrajectory(a.keyframes, kf_traj); !s.ok()) {
      std::cerr << "error: " << s.message() << "\n";
      rc = 1;
    }
  }
  std::printf("frames %zu, tracked %zu, lost %d, keyframes %d\n", n, traj.size(), lost, keyframes);
  if (stage.detected_keyframes() > 0) {
    std::printf("detection: %d keyframes, %.1f ms each\n", stage.detected_keyframes(),
                stage.detect_ms_total() / stage.detected_keyframes());
  }
  if (masking && keyframes > 0) {
    std::printf("object masks: %.1f ms per keyframe\n", stage.mask_ms_total() / keyframes);
  }
  if (client) {
    Status s = client->Close();
    const MapClientStats st = client->stats();
    std::printf(
        "streamed to %s: session %s, queued %ld, acked %ld (duplicates %ld), "
        "rejected %ld, reconnects %ld, %.1f MB sent\n",
        a.server.c_str(), client->session_id().c_str(), st.queued, st.acked, st.duplicates,
        st.rejected, st.reconnects, st.bytes_sent / 1e6);
    if (!s.ok() || !stage_status.ok() || st.rejected > 0) {
      std::cerr << "error: " << (!s.ok() ? s.message() : stage_status.message()) << " "
                << st.last_error << "\n";
      rc = 1;
    }
  }
  return rc;
}

}  // namespace
}  // namespace loci

int main(int argc, char** argv) {
  CLI::App app{"loci-track: RGB-D tracking client of the loci semantic map"};
  loci::Args a;
  std::string log_level = "info";
  app.add_option("--tum", a.tum_dir, "TUM RGB-D folder (rgb.txt, depth.txt)")->required();
  app.add_option("--server", a.server, "loci-server HOST:PORT")->capture_default_str();
  app.add_option("--robot", a.robot, "robot name")->capture_default_str();
  app.add_flag("--offline", a.offline, "do not stream (trajectory files only)");
  app.add_option("--trajectory", a.trajectory, "write the TUM trajectory of every frame");
  app.add_option("--keyframes", a.keyframes, "write the TUM trajectory of the keyframes");
  app.add_option("--poses", a.poses, "take poses from this TUM trajectory instead of odometry");
  app.add_option("--detections", a.detections,
                 "detections.jsonl, or 'none'; default: run the configured detector");
  app.add_option("--model", a.model, "detector ONNX model (overrides config/detection.yaml)");
  app.add_option("--config", a.config, "client YAML (default: config/client.yaml)");
  app.add_option("--max-frames", a.max_frames, "stop after N frames (0 = all)");
  app.add_flag("--no-progress", a.no_progress, "no progress bar on stderr");
  app.add_option("--log-level", log_level, "trace|debug|info|warn|error");
  CLI11_PARSE(app, argc, argv);
  spdlog::set_level(spdlog::level::from_str(log_level));
  return loci::Run(a);
}
