// loci-track: the tracking client. Runs RGB-D odometry over a TUM folder (or takes poses from a
// trajectory file), selects keyframes, attaches detections and gravity, and streams keyframes to
// loci-server. See `loci-track --help`.
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <iostream>
#include <memory>

#include "client/app/keyframe_stage.h"
#include "client/app/pose_source.h"
#include "client/app/track_pipeline.h"
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
  std::string poses, detections, model, site;
  ChannelSecurity security;
  bool offline = false, no_progress = false, live = false, strict_config = false;
  int start_frame = 0;
  int max_frames = 0;
};

// A failure with its exit code (2: bad input or config, 3: no server, 1: run failed).
struct Failure {
  int code;
  std::string message;
};

// Detections: a file (also the odometry's dynamic prior), none, or the configured detector and
// tracker on keyframes; masks from config/detection.yaml for any detections.
struct DetectionSetup {
  std::vector<FrameDetections> file_dets;
  std::unique_ptr<detection::Detector> detector;
  std::unique_ptr<detection::MultiObjectTracker> mot;
  std::optional<KeyframeMasking> masking;
};

std::optional<Failure> SetUpDetection(const Args& a, const TrackerOptions& topt,
                                      DetectionSetup* out) {
  if (a.detections == "none") return std::nullopt;
  auto dc = detection::LoadDetectionConfig(detection::DefaultDetectionConfigPath());
  if (!dc.ok()) return Failure{2, std::string(dc.status().message())};
  out->masking = KeyframeMasking{dc->mask, topt.camera};
  out->masking->options.depth_scale = static_cast<float>(topt.depth_scale);
  if (!a.detections.empty()) {
    auto d = ReadDetectionsJsonl(a.detections);
    if (!d.ok()) return Failure{2, std::string(d.status().message())};
    out->file_dets = std::move(*d);
    return std::nullopt;
  }
  if (!a.model.empty()) dc->detector.model_path = a.model;
  auto det = detection::MakeDetector(dc->detector);
  if (!det.ok()) {
    return Failure{2, absl::StrCat("detector: ", det.status().message(),
                                   " (use --detections FILE or --detections none)")};
  }
  out->detector = std::move(*det);
  out->mot = std::make_unique<detection::MultiObjectTracker>(dc->tracker);
  return std::nullopt;
}

int WriteTrajectories(const Args& a, const TrackPipelineResult& r) {
  int rc = 0;
  for (const auto& [path, traj] : {std::pair{a.trajectory, &r.trajectory},
                                   std::pair{a.keyframes, &r.keyframe_trajectory}}) {
    if (path.empty()) continue;
    if (Status s = WriteTumTrajectory(path, *traj); !s.ok()) {
      std::cerr << "error: " << s.message() << "\n";
      rc = 1;
    }
  }
  return rc;
}

void PrintSummary(const TrackPipelineResult& r, const KeyframeStage& stage, bool masks) {
  std::printf("frames %zu, tracked %zu, lost %zu, keyframes %zu\n", r.frames, r.tracked, r.lost,
              r.keyframes);
  if (stage.detected_keyframes() > 0) {
    std::printf("detection: %d keyframes, %.1f ms each\n", stage.detected_keyframes(),
                stage.detect_ms_total() / stage.detected_keyframes());
  }
  if (masks && r.keyframes > 0) {
    std::printf("object masks: %.1f ms per keyframe\n", stage.mask_ms_total() / r.keyframes);
  }
}

int CloseStream(const Args& a, MapClient& client, const Status& stage_status) {
  Status s = client.Close();
  const MapClientStats st = client.stats();
  std::printf(
      "streamed to %s: session %s, queued %ld, acked %ld (duplicates %ld), "
      "rejected %ld, reconnects %ld, %.1f MB sent\n",
      a.server.c_str(), client.session_id().c_str(), st.queued, st.acked, st.duplicates,
      st.rejected, st.reconnects, st.bytes_sent / 1e6);
  if (s.ok() && stage_status.ok() && st.rejected == 0) return 0;
  std::cerr << "error: " << (!s.ok() ? s.message() : stage_status.message()) << " "
            << st.last_error << "\n";
  return 1;
}

int Run(const Args& a) {
  auto config = LoadClientConfig(a.config, a.tum_dir);
  auto seq = LoadTumSequence(a.tum_dir);
  for (const Status& s : {config.status(), seq.status()}) {
    if (!s.ok()) {
      std::cerr << "error: " << s.message() << "\n";
      return 2;
    }
  }
  const TrackerOptions& topt = config->tracker;
  MapClientOptions& mopt = config->streaming;
  mopt.server = a.server;
  mopt.robot_name = a.robot;
  mopt.site = a.site;
  mopt.security = a.security.WithEnvironment();
  DetectionSetup det;
  if (auto f = SetUpDetection(a, topt, &det)) {
    std::cerr << "error: " << f->message << "\n";
    return f->code;
  }
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
  const bool masks = det.masking.has_value();
  KeyframeStage::Sink sink;
  if (client) sink = [&](KeyframeData kf) { return client->Send(std::move(kf)).status(); };
  KeyframeStage stage(std::move(det.detector), std::move(det.mot), std::move(sink),
                      a.live ? 4 : 0, std::move(det.masking));
  std::unique_ptr<Tracker> tracker;
  std::unique_ptr<PoseSource> pose_source;
  Status made = absl::OkStatus();
  if (!a.poses.empty()) {
    auto p = PoseSource::FromFile(a.poses, topt.keyframes);
    made = p.status();
    if (p.ok()) pose_source = std::move(*p);
  } else {
    auto t = Tracker::Create(topt);
    made = t.status();
    if (t.ok()) tracker = std::move(*t);
  }
  if (!made.ok()) {
    std::cerr << "error: " << made.message() << "\n";
    return 2;
  }
  TrackPipelineOptions po;
  po.start_frame = static_cast<size_t>(a.start_frame);
  po.max_frames = a.max_frames > 0 ? static_cast<size_t>(a.max_frames) : 0;
  po.progress = !a.no_progress;
  po.camera = topt.camera;
  po.distortion = topt.distortion;
  auto r = RunTrackPipeline(*seq, tracker.get(), pose_source.get(), det.file_dets, stage, po);
  const Status stage_status = stage.Finish();
  if (!r.ok()) {
    std::cerr << "error: " << r.status().message() << "\n";
    return 1;
  }
  int rc = WriteTrajectories(a, *r);
  PrintSummary(*r, stage, masks);
  if (client) rc = std::max(rc, CloseStream(a, *client, stage_status));
  return rc;
}

}  // namespace
}  // namespace loci

int main(int argc, char** argv) {
  CLI::App app{"loci-track: RGB-D tracking client of the loci semantic map"};
  loci::Args a;
  std::string log_level = "info";
  app.add_option("--tum", a.tum_dir,
                 "TUM RGB-D folder (rgb.txt, depth.txt; its camera.yaml, when present, gives the "
                 "intrinsics, lens distortion and rolling-shutter line_time_us, else "
                 "tracker.camera of --config, else the Kinect its TUM name gives "
                 "(rgbd_dataset_freiburg3_*, tum_fr2_*), else TUM fr1's; frames are undistorted "
                 "and rectified of the rolling shutter first)")
      ->required();
  app.add_option("--server", a.server, "loci-server HOST:PORT")->capture_default_str();
  app.add_option("--robot", a.robot, "robot name")->capture_default_str();
  app.add_option("--site", a.site,
                 "the site (map) the robot maps; the server refuses another site's robots "
                 "[the server's site]");
  app.add_option("--token", a.security.token, "bearer token (default: $LOCI_TOKEN)");
  app.add_option("--tls-ca", a.security.tls_ca_file,
                 "CA certificate (PEM) of a TLS server (default: $LOCI_TLS_CA; none: plaintext)");
  app.add_flag("--offline", a.offline, "do not stream (trajectory files only)");
  app.add_flag("--live", a.live,
               "run the detector on its own thread as on a robot (tracking keeps its rate; the "
               "map then depends on timing); default: each keyframe is detected before the next "
               "frame is tracked, so the same data gives the same map");
  app.add_option("--trajectory", a.trajectory, "write the TUM trajectory of every frame");
  app.add_option("--keyframes", a.keyframes, "write the TUM trajectory of the keyframes");
  app.add_option("--poses", a.poses, "take poses from this TUM trajectory instead of odometry");
  app.add_option("--detections", a.detections,
                 "detections.jsonl, or 'none'; default: run the configured detector");
  app.add_option("--model", a.model, "detector ONNX model (overrides config/detection.yaml)");
  app.add_option("--config", a.config, "client YAML (default: config/client.yaml)");
  app.add_option("--start-frame", a.start_frame,
                 "start at this frame of rgb.txt (0-based); odometry starts at the identity there")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--max-frames", a.max_frames, "stop after N frames (0 = all)");
  app.add_flag("--no-progress", a.no_progress, "no progress on stderr");
  app.add_option("--log-level", log_level, "trace|debug|info|warn|error");
  app.add_flag("--strict-config", a.strict_config, "unknown keys in the YAML files are errors");
  CLI11_PARSE(app, argc, argv);
  loci::SetStrictConfig(a.strict_config);
  spdlog::set_level(spdlog::level::from_str(log_level));
  return loci::Run(a);
}
