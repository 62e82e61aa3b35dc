// The tracking client's main loop over a recorded sequence, shared by loci-track and
// `loci bench report`: odometry (or a pose file) on every frame, with the latest keyframe's boxes
// (at most max_box_age_ns old) as the dynamic prior, and every keyframe handed to a
// KeyframeStage (detector, tracker, masks, sink). With a synchronous stage the run is
// repeatable: the same input gives the same keyframes and detections.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "client/app/keyframe_stage.h"
#include "client/app/pose_source.h"
#include "client/streaming/map_client.h"
#include "client/tracking/tracker.h"
#include "common/detections_io.h"
#include "common/tum_io.h"

namespace loci {

// The options of a run, from the client YAML ("" = config/client.yaml, skipped when absent),
// the class weights of config/classes.yaml and the sequence's camera.yaml when present. Every
// file that is there must parse: a bad camera.yaml is an error, not a silent default. Unknown
// keys (top level, `tracker`, `streaming`, camera.yaml) warn, or fail with strict checking.
struct ClientConfig {
  TrackerOptions tracker;      // `tracker`, class weights, the sequence's camera and depth units
  MapClientOptions streaming;  // `streaming`; server and robot name keep their defaults
};
StatusOr<ClientConfig> LoadClientConfig(const std::string& client_config,
                                        const std::string& tum_dir);

struct TrackPipelineOptions {
  int64_t max_box_age_ns = 300'000'000;  // dynamic prior: boxes at most this old (0.3 s)
  size_t start_frame = 0;                // first frame (index in rgb.txt) to track
  size_t max_frames = 0;                 // frames from start_frame on; 0 = to the end
  bool progress = false;                 // progress on stderr
  // The raw images' camera and lens distortion (TrackerOptions::camera, ::distortion): every
  // frame is undistorted (FrameUndistorter) before odometry, detection and streaming. Zero
  // distortion: the images are used as read.
  PinholeCamera camera = PinholeCamera::TumFr1();
  LensDistortion distortion;
};

struct TrackPipelineResult {
  size_t frames = 0, tracked = 0, lost = 0, keyframes = 0;
  Trajectory trajectory, keyframe_trajectory;  // T_odom_cam
  double track_ms = 0;                         // sum of Track() / At() wall times
};

// Runs the loop. `tracker` or `poses` (exactly one non-null) gives the poses; `file_dets` (may
// be empty) gives detections by stamp. Keyframe sink errors surface from stage.Finish().
StatusOr<TrackPipelineResult> RunTrackPipeline(const TumSequence& seq, Tracker* tracker,
                                               PoseSource* poses,
                                               const std::vector<FrameDetections>& file_dets,
                                               KeyframeStage& stage,
                                               const TrackPipelineOptions& options);

}  // namespace loci
