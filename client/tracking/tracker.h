// loci::Tracker: RGB-D visual odometry for the tracking client, called frame by frame.
//
//   auto tracker = loci::Tracker::Create(options);          // StatusOr<unique_ptr<Tracker>>
//   for each frame: auto r = (*tracker)->Track(bgr, depth_u16, t_ns, &detections_or_null);
//   r->T_odom_cam is T_odom_cam of the frame (odom = the first frame's camera); r->keyframe says
//   whether to stream it.
//
// Pipeline per frame: grid-distributed ORB -> 3-D points from depth -> projection search of the
// local map (last N keyframes) around the constant-velocity prediction -> PnP-RANSAC on
// features outside dynamic boxes -> Gauss-Newton/Huber refinement (reprojection + depth) ->
// dynamic test (epipolar + depth error, class-weighted threshold) -> second, tighter search ->
// final refinement on static features -> keyframe decision (effective motion + static
// co-visibility, papers 004/001) -> local map upkeep. Tracking loss: relocalise against the
// window keyframes, else start a new odometry segment (FrameResult::segment increments).
#pragma once

#include <memory>
#include <optional>
#include <opencv2/core.hpp>
#include <vector>

#include "client/tracking/dynamic_filter.h"
#include "client/tracking/local_map.h"
#include "client/tracking/matcher.h"
#include "client/tracking/orb_frame.h"
#include "client/tracking/tracker_options.h"
#include "common/detections_io.h"
#include "common/se3.h"
#include "common/status.h"

namespace loci {

enum class TrackState { kInitialised, kTracking, kRelocalised, kLost, kNewSegment };
const char* TrackStateName(TrackState s);

struct FrameResult {
  int64_t t_ns = 0;
  TrackState state = TrackState::kLost;
  bool tracked = false;  // false: T_odom_cam is only the motion-model prediction
  SE3d T_odom_cam = SE3d::Identity();
  bool keyframe = false;  // a new keyframe was created from this frame
  int segment = 0;        // odometry segment (increments after an unrecoverable loss)
  int num_features = 0;
  int num_matches = 0;
  int num_inliers = 0;
  int num_dynamic = 0;  // matched features flagged dynamic
  int num_map_points = 0;
  double track_ms = 0;  // wall time of Track(), ms
};

class Tracker {
 public:
  static StatusOr<std::unique_ptr<Tracker>> Create(const TrackerOptions& options);

  // image: CV_8UC3 BGR or CV_8UC1 grey; depth_u16: CV_16UC1 in options.depth_scale units per
  // metre, same size as the camera. detections: boxes of this image (nullptr / empty: none;
  // the geometric test still runs). InvalidArgument on bad input; never aborts.
  StatusOr<FrameResult> Track(const cv::Mat& image, const cv::Mat& depth_u16, int64_t t_ns,
                              const std::vector<Detection2D>* detections = nullptr);

  // The camera's motion from from_t_ns to to_t_ns under the constant-velocity model of the last
  // two tracked frames, T_cam(to)_cam(from) (rotation angle and translation scaled with time);
  // nullopt before two frames are tracked in a row, when the model spans no time, or for a span
  // longer than the model's own (one frame interval: a velocity is not extrapolated further).
  std::optional<SE3d> PredictedMotion(int64_t from_t_ns, int64_t to_t_ns) const;
  // The camera's turn rate (cam frame, rad/s) over the last two tracked frame steps (their mean:
  // one step's rate carries that frame's pose error back into the next frame's correction);
  // the last step's alone after a single one; before two frames are tracked in a row, the
  // seeded rate (SeedTurnRate) if any, else nullopt.
  std::optional<Vec3d> RecentTurnRate() const;
  // The turn rate RecentTurnRate gives before the tracker has measured one of its own (a
  // sequence's first two frames; SeedTurnRateFromSequence in rolling_shutter.h measures it).
  void SeedTurnRate(const Vec3d& w_cam_rad_s) { seed_w_cam_rad_s_ = w_cam_rad_s; }

  const TrackerOptions& options() const { return opt_; }
  int segment() const { return segment_; }

 private:
  explicit Tracker(const TrackerOptions& options);

  // Tracks `frame` from the initial pose; fills matches (inlier / dynamic flags) and pose.
  int TrackLocalMap(const OrbFrame& frame, const SE3d& T_cw_init, SE3d* T_cw,
                    std::vector<PointMatch>* matches);
  bool Relocalise(const OrbFrame& frame, SE3d* T_cw_init);
  bool NeedKeyframe(const OrbFrame& frame, const SE3d& T_cw, const std::vector<PointMatch>& matches,
                    int num_inliers) const;
  void CreateKeyframe(OrbFrame frame, const SE3d& T_cw, const std::vector<PointMatch>& matches);
  // A segment's first keyframe, at the last known pose: no velocity; r says tracked, keyframe.
  void StartSegment(OrbFrame frame, int64_t t_ns, FrameResult* r);
  // TrackLocalMap from the prediction, else from a relocalisation (state kRelocalised then).
  // Returns the inliers (0 when relocalisation failed).
  int TrackOrRelocalise(const OrbFrame& frame, const SE3d& T_cw_pred, SE3d* T_cw,
                        std::vector<PointMatch>* matches, TrackState* state);
  // Counts the tracked frame on its matched map points; returns the dynamic matches.
  int MarkMatchedPoints(const OrbFrame& frame, const SE3d& T_cw,
                        const std::vector<PointMatch>& matches);
  // Local bundle adjustment after a new keyframe; the tracker and r continue from its pose.
  void AdjustNewKeyframe(FrameResult* r);
  // Starts the constant-velocity model from the step last -> T_cw at t_ns.
  void UpdateVelocity(const SE3d& T_cw, int64_t t_ns);

  TrackerOptions opt_;
  OrbExtractor extractor_;
  DynamicFilter dynamic_;
  LocalMap map_;
  int64_t frame_index_ = -1;
  int64_t last_kf_frame_ = -1;
  int64_t next_kf_id_ = 1;
  int segment_ = 0;
  int lost_count_ = 0;
  bool have_velocity_ = false;
  SE3d T_cw_last_ = SE3d::Identity();  // last tracked pose, T_cam_world
  SE3d velocity_ = SE3d::Identity();   // T_cam_prevcam of the last two tracked frames
  int64_t velocity_dt_ns_ = 0;         // ... and the time between them
  // The turn rate (cam frame, rad/s) of the step before velocity_'s, when it was tracked too.
  std::optional<Vec3d> prev_w_cam_rad_s_;
  std::optional<Vec3d> seed_w_cam_rad_s_;  // SeedTurnRate's, until the first measured step
  int64_t last_t_ns_ = 0;              // stamp of the frame T_cw_last_ belongs to
};

}  // namespace loci
