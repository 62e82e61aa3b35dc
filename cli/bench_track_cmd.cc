// `loci bench track --tum DIR [--threads 1] [--max-frames N] [--config FILE]`: runs the tracking
// client's visual odometry over a TUM folder and prints per-frame tracking time (median, p95),
// keyframes/s, encoded bytes per keyframe (JPEG q90 + 16-bit PNG, encoding not timed as
// tracking) and ATE / RPE when groundtruth.txt exists. The options are loci-track's: the client
// YAML and the folder's camera.yaml, and frames are undistorted as loci-track does.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "cli/bench_stats.h"
#include "cli/commands.h"
#include "client/app/track_pipeline.h"
#include "client/tracking/depth_time_warp.h"
#include "client/tracking/frame_undistorter.h"
#include "client/tracking/rolling_shutter.h"
#include "client/tracking/tracker.h"
#include "common/clock_offset.h"
#include "common/config.h"
#include "common/image_codec.h"
#include "common/time.h"
#include "common/trajectory_eval.h"
#include "common/tum_io.h"

namespace loci::cli {
namespace {

struct BenchTrackArgs {
  std::string tum_dir;
  int threads = 1;
  int max_frames = 0;
  std::string config;
  std::string trajectory_out;
  bool no_dynamic = false;
  bool verbose = false;
};

int RunBenchTrack(const BenchTrackArgs& a) {
  cv::setNumThreads(a.threads);
  auto config = LoadClientConfig(a.config, a.tum_dir);
  if (!config.ok()) {
    std::cerr << "error: " << config.status().message() << "\n";
    return 1;
  }
  TrackerOptions& opt = config->tracker;
  if (a.no_dynamic) opt.dynamic.enabled = false;
  auto seq = LoadTumSequence(a.tum_dir);
  if (!seq.ok()) {
    std::cerr << "error: " << seq.status().message() << "\n";
    return 1;
  }
  auto tracker = Tracker::Create(opt);
  if (!tracker.ok()) {
    std::cerr << "error: " << tracker.status().message() << "\n";
    return 1;
  }
  const FrameUndistorter undistort(opt.camera, opt.distortion);
  std::vector<double> ms, rectify_ms;
  Trajectory est;
  size_t keyframes = 0, kf_bytes = 0, lost = 0, segments = 0;
  double total_track_s = 0;
  const size_t n =
      a.max_frames > 0 ? std::min<size_t>(a.max_frames, seq->frames.size()) : seq->frames.size();
  SeedTurnRateFromSequence(*seq, 0, undistort, tracker->get());
  for (size_t i = 0; i < n; ++i) {
    const TumFrame& f = seq->frames[i];
    cv::Mat bgr = cv::imread(f.rgb_path, cv::IMREAD_COLOR);
    cv::Mat depth = cv::imread(f.depth_path, cv::IMREAD_UNCHANGED);
    if (Status s = undistort.Apply(&bgr, &depth); !s.ok()) {
      std::cerr << "error: frame " << i << ": " << s.message() << "\n";
      return 1;
    }
    AlignDepthToColourTime(**tracker, f.depth_t_ns, f.rgb_t_ns, &depth);
    const auto t_rectify = std::chrono::steady_clock::now();
    RectifyRollingShutter(**tracker, &bgr, &depth);
    rectify_ms.push_back(MsSince(t_rectify));
    auto r = (*tracker)->Track(bgr, depth, f.rgb_t_ns);
    if (!r.ok()) {
      std::cerr << "error: frame " << i << ": " << r.status().message() << "\n";
      return 1;
    }
    ms.push_back(r->track_ms);
    if (a.verbose) {
      std::fprintf(stderr, "%zu %s kf=%d feat=%d match=%d inl=%d dyn=%d pts=%d %.1fms\n", i,
                   TrackStateName(r->state), r->keyframe, r->num_features, r->num_matches,
                   r->num_inliers, r->num_dynamic, r->num_map_points, r->track_ms);
    }
    total_track_s += r->track_ms * 1e-3;
    lost += !r->tracked;
    segments = std::max<size_t>(segments, r->segment);
    if (r->tracked) est.push_back({f.rgb_t_ns, r->T_odom_cam});
    if (r->keyframe) {
      ++keyframes;
      auto jpg = EncodeJpeg(bgr, 90);
      auto png = EncodeDepthPng(depth);
      if (jpg.ok() && png.ok()) kf_bytes += jpg->size() + png->size();
    }
  }
  std::printf("frames            %zu (lost %zu, new segments %zu)\n", n, lost, segments);
  std::printf("tracking ms/frame median %.2f  p95 %.2f  mean %.2f  (threads %d)\n",
              Percentile(ms, 0.5), Percentile(ms, 0.95),
              total_track_s * 1e3 / std::max<size_t>(1, n), a.threads);
  std::printf("rolling shutter   %.0f us per row; rectifying ms/frame median %.2f  p95 %.2f\n",
              opt.line_time_us, Percentile(rectify_ms, 0.5), Percentile(rectify_ms, 0.95));
  std::printf(
      "keyframes         %zu  (%.2f keyframes/s of sequence time, %.1f per 100 frames)\n",
      keyframes,
      n > 1 ? keyframes / NsToSeconds(seq->frames[n - 1].rgb_t_ns - seq->frames[0].rgb_t_ns) : 0.0,
      100.0 * keyframes / std::max<size_t>(1, n));
  std::printf("bytes/keyframe    %.0f (JPEG q90 + 16-bit PNG depth)\n",
              keyframes ? static_cast<double>(kf_bytes) / keyframes : 0.0);
  if (!a.trajectory_out.empty()) (void)WriteTumTrajectory(a.trajectory_out, est);
  if (!seq->groundtruth.empty()) {
    auto ate = ComputeAte(seq->groundtruth, est);
    auto rpe = ComputeRpe(seq->groundtruth, est);
    if (ate.ok()) {
      std::printf("ATE RMSE          %.4f m  (median %.4f, max %.4f, %zu pairs)\n",
                  ate->trans_m.rmse, ate->trans_m.median, ate->trans_m.max, ate->pairs);
    }
    if (rpe.ok()) {
      std::printf("RPE RMSE (1 s)    %.4f m/s  %.3f deg/s\n", rpe->trans_m.rmse,
                  rpe->rot_rad.rmse * 180.0 / M_PI);
    }
    if (auto clock = EstimateClockOffset(seq->groundtruth, est); clock.ok()) {
      std::printf("clock offset      %+.0f ms: the ground truth read this far from each image's "
                  "stamp fits the orientations best (rms %.2f deg at the stamps, %.2f deg there)\n",
                  clock->offset_ns * 1e-6, clock->rms_deg_at_zero, clock->rms_deg);
    }
  }
  return 0;
}

}  // namespace

void RegisterBenchTrackCommand(CLI::App& app) {
  CLI::App* bench = BenchGroup(app);
  auto args = std::make_shared<BenchTrackArgs>();
  CLI::App* c =
      bench->add_subcommand("track", "visual odometry speed and accuracy on a TUM folder");
  c->add_option("--tum", args->tum_dir, "TUM RGB-D folder")->required();
  c->add_option("--threads", args->threads, "OpenCV threads")->capture_default_str();
  c->add_option("--max-frames", args->max_frames, "stop after N frames (0 = all)");
  c->add_option("--config", args->config, "client YAML (default: config/client.yaml)");
  c->add_option("--trajectory", args->trajectory_out, "write the TUM trajectory here");
  c->add_flag("--verbose", args->verbose, "per-frame tracking statistics on stderr");
  c->add_flag("--no-dynamic", args->no_dynamic, "disable dynamic-feature suppression");
  c->callback([args] { ExitCode() = RunBenchTrack(*args); });
}

}  // namespace loci::cli
