#include "client/app/track_pipeline.h"

#include <spdlog/spdlog.h>

#include <cstdio>
#include <opencv2/imgcodecs.hpp>

#include "absl/strings/match.h"
#include "client/tracking/depth_time_warp.h"
#include "client/tracking/frame_undistorter.h"
#include "client/tracking/rolling_shutter.h"
#include "common/config.h"
#include "common/progress.h"

namespace loci {
namespace {

// A progress bar on a terminal; a line every 10 % otherwise (logs stay readable).
void Progress(size_t i, size_t n, size_t kfs, const FrameResult& r) {
  if (StderrIsTerminal()) {
    std::fprintf(stderr, "\r%s %zu/%zu  kf %zu  inliers %d  %.1f ms   ",
                 ProgressBar(i + 1, n, 30).c_str(), i + 1, n, kfs, r.num_inliers, r.track_ms);
    if (i + 1 == n) std::fprintf(stderr, "\n");
  } else if (AtProgressStep(i + 1, n)) {
    std::fprintf(stderr, "frame %zu/%zu, keyframes %zu\n", i + 1, n, kfs);
  }
}

// Detections for the odometry's dynamic prior on this frame.
std::vector<Detection2D> PriorFor(const TumFrame& f, const std::vector<FrameDetections>& file_dets,
                                  const KeyframeStage& stage, int64_t max_age_ns,
                                  bool* from_file) {
  *from_file = false;
  if (const FrameDetections* fd = FindDetections(file_dets, f.rgb_t_ns)) {
    *from_file = true;
    return fd->detections;
  }
  FrameDetections latest = stage.LatestDetections();
  if (latest.t_ns > 0 && f.rgb_t_ns - latest.t_ns <= max_age_ns) return latest.detections;
  return {};
}

// `s` with the file it is about in front of its message (when not already there).
Status WithFile(const std::string& path, const Status& s) {
  if (s.ok() || absl::StartsWith(s.message(), path)) return s;
  return absl::Status(s.code(), absl::StrCat(path, ": ", s.message()));
}

Status ReadStreamingOptions(const YAML::Node& n, MapClientOptions* out) {
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(n, "streaming", {"max_unacked", "jpeg_quality"}));
  LOCI_RETURN_IF_ERROR(ReadOptional(n, "max_unacked", &out->max_unacked));
  return ReadOptional(n, "jpeg_quality", &out->jpeg_quality);
}

// The client YAML: sections `tracker` and `streaming`.
Status ReadClientYaml(const std::string& path, const YAML::Node& root, ClientConfig* out) {
  const ConfigFileScope scope(path);
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(root, "", {"tracker", "streaming"}));
  LOCI_RETURN_IF_ERROR(out->tracker.FromYaml(root["tracker"]));
  return ReadStreamingOptions(root["streaming"], &out->streaming);
}

// A sequence's camera.yaml: the intrinsics (a `camera:` section, or its keys at the top level)
// and `depth_scale` (depth PNG units per metre).
Status ReadSequenceCamera(const std::string& path, const YAML::Node& root, TrackerOptions* out) {
  const ConfigFileScope scope(path);
  CameraCalibration cal;
  if (root["camera"]) {
    LOCI_RETURN_IF_ERROR(CheckKnownKeys(root, "", {"camera", "depth_scale"}));
    LOCI_ASSIGN_OR_RETURN(cal, CameraFromYaml(root["camera"]));
  } else {
    YAML::Node intrinsics = YAML::Clone(root);  // the top-level form: every key but depth_scale
    intrinsics.remove("depth_scale");
    LOCI_ASSIGN_OR_RETURN(cal, CameraFromYaml(intrinsics));
  }
  out->SetCamera(cal);
  return ReadOptional(root, "depth_scale", &out->depth_scale);
}

// A folder without camera.yaml and a config that names no camera: the Kinect the folder's TUM
// name gives (fr1's calibration on an fr3 sequence bends its images by up to 26 px at the rim).
Status UseFolderCamera(const std::string& tum_dir, TrackerOptions* out) {
  const std::string preset = TumCameraPresetForFolder(tum_dir);
  if (preset.empty()) {
    spdlog::info("{}: no camera.yaml and no TUM freiburg name: camera as configured ({:.1f} px)",
                 tum_dir, out->camera.fx);
    return absl::OkStatus();
  }
  LOCI_ASSIGN_OR_RETURN(const CameraCalibration cal, CameraPreset(preset));
  out->SetCamera(cal);
  spdlog::info("{}: no camera.yaml; camera {} from the folder's name", tum_dir, preset);
  return absl::OkStatus();
}

}  // namespace

StatusOr<ClientConfig> LoadClientConfig(const std::string& client_config,
                                        const std::string& tum_dir) {
  ClientConfig c;
  const std::string path =
      client_config.empty() ? SourceDir() + "/config/client.yaml" : client_config;
  StatusOr<YAML::Node> node = LoadYamlFile(path);
  const bool shipped_absent = client_config.empty() && absl::IsNotFound(node.status());
  if (!node.ok() && !shipped_absent) return node.status();
  if (node.ok()) LOCI_RETURN_IF_ERROR(WithFile(path, ReadClientYaml(path, *node, &c)));
  const std::string classes = SourceDir() + "/config/classes.yaml";
  StatusOr<YAML::Node> weights = LoadYamlFile(classes);
  if (!weights.ok() && !absl::IsNotFound(weights.status())) return weights.status();
  if (weights.ok()) {
    LOCI_RETURN_IF_ERROR(WithFile(classes, c.tracker.ClassWeightsFromYaml(*weights)));
  }
  const std::string camera = tum_dir + "/camera.yaml";
  const bool configured = node.ok() && (*node)["tracker"] && (*node)["tracker"]["camera"];
  if (access(camera.c_str(), F_OK) == 0) {
    LOCI_ASSIGN_OR_RETURN(YAML::Node cam, LoadYamlFile(camera));
    LOCI_RETURN_IF_ERROR(WithFile(camera, ReadSequenceCamera(camera, cam, &c.tracker)));
  } else if (!tum_dir.empty() && !configured) {
    LOCI_RETURN_IF_ERROR(UseFolderCamera(tum_dir, &c.tracker));
  }
  return c;
}

StatusOr<TrackPipelineResult> RunTrackPipeline(const TumSequence& seq, Tracker* tracker,
                                               PoseSource* poses,
                                               const std::vector<FrameDetections>& file_dets,
                                               KeyframeStage& stage,
                                               const TrackPipelineOptions& o) {
  if ((tracker == nullptr) == (poses == nullptr)) {
    return absl::InvalidArgumentError("give exactly one of a tracker and a pose source");
  }
  TrackPipelineResult r;
  const size_t first = std::min(o.start_frame, seq.frames.size());
  const size_t left = seq.frames.size() - first;
  const size_t n = first + (o.max_frames > 0 ? std::min(o.max_frames, left) : left);
  const FrameUndistorter undistort(o.camera, o.distortion);
  if (tracker) SeedTurnRateFromSequence(seq, first, undistort, tracker);
  for (size_t i = first; i < n; ++i) {
    const TumFrame& f = seq.frames[i];
    cv::Mat bgr = cv::imread(f.rgb_path, cv::IMREAD_COLOR);
    cv::Mat depth = cv::imread(f.depth_path, cv::IMREAD_UNCHANGED);
    if (bgr.empty() || depth.empty()) {
      spdlog::warn("frame {}: unreadable image, skipped", i);
      continue;
    }
    if (Status s = undistort.Apply(&bgr, &depth); !s.ok()) {
      spdlog::warn("frame {}: {}, skipped", i, std::string(s.message()));
      continue;
    }
    ++r.frames;
    bool from_file = false;
    std::vector<Detection2D> dets = PriorFor(f, file_dets, stage, o.max_box_age_ns, &from_file);
    if (tracker) AlignDepthToColourTime(*tracker, f.depth_t_ns, f.rgb_t_ns, &depth);
    if (tracker) RectifyRollingShutter(*tracker, &bgr, &depth);
    StatusOr<FrameResult> fr = tracker ? tracker->Track(bgr, depth, f.rgb_t_ns, &dets)
                                       : poses->At(f.rgb_t_ns);
    if (!fr.ok()) {
      spdlog::warn("frame {}: {}", i, std::string(fr.status().message()));
      continue;
    }
    r.track_ms += fr->track_ms;
    if (o.progress) Progress(i, n, r.keyframes, *fr);
    if (!fr->tracked) {
      ++r.lost;
      continue;
    }
    ++r.tracked;
    r.trajectory.push_back({f.rgb_t_ns, fr->T_odom_cam});
    if (!fr->keyframe) continue;
    ++r.keyframes;
    r.keyframe_trajectory.push_back({f.rgb_t_ns, fr->T_odom_cam});
    KeyframeData kf;
    kf.t_ns = f.rgb_t_ns;
    kf.T_odom_cam = fr->T_odom_cam;
    kf.bgr = bgr;
    kf.depth_u16 = depth;
    if (from_file) kf.detections = std::move(dets);  // else: the stage's detector fills them
    kf.segment = fr->segment;
    kf.tracking_inliers = fr->num_inliers;  // 0 with --poses: unknown
    if (auto g = GravityInCamAt(seq.accel, f.rgb_t_ns); g.ok()) kf.gravity_cam = *g;
    LOCI_RETURN_IF_ERROR(stage.Push(std::move(kf)));
  }
  return r;
}

}  // namespace loci
