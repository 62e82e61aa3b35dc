// DeepSORT-style multi-object tracker (paper 000, section 3.1): a Kalman filter per track on
// the box, matching cascade by track age on a cost that mixes motion (IoU / Mahalanobis) and
// appearance (HSV histogram), then an IoU stage for young tracks; tracks are confirmed after
// n_init hits and deleted after max_age missed updates. A track never changes class.
#pragma once

#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "common/detections_io.h"
#include "common/status.h"
#include "detection/appearance.h"
#include "detection/kalman_box.h"

namespace loci::detection {

struct TrackerOptions {
  // Hits before a track is confirmed and its id is reported. Default 2 (keyframes are sparse).
  int n_init = 2;
  // Consecutive updates a confirmed track may miss and still be matched again; one more miss
  // deletes it. Default 30.
  int max_age = 30;
  // Motion gate: a pair is feasible when IoU(predicted, detection) >= min_iou or the squared
  // Mahalanobis distance <= mahalanobis_gate (chi-square 4 dof, 95 % = 9.4877).
  float min_iou = 0.1f;
  double mahalanobis_gate = 9.4877;
  // Appearance gate: Bhattacharyya distance above this rejects a pair (when images are given).
  double max_appearance_distance = 0.6;
  // Cascade cost = motion_weight * motion + (1 - motion_weight) * appearance, where motion =
  // min(1 - IoU, d^2 / mahalanobis_gate); pairs above max_cascade_cost are rejected.
  double motion_weight = 0.5;
  double max_cascade_cost = 0.7;
  // Second (IoU-only) stage for tentative tracks and tracks missed once: 1 - IoU must be
  // <= max_iou_distance. Default 0.7 (DeepSORT).
  double max_iou_distance = 0.7;
  // Appearance of a track: exponential moving average, weight of the old feature. Default 0.8.
  double appearance_momentum = 0.8;
  // Kalman noise as fractions of the box height (DeepSORT values).
  double std_weight_position = 1.0 / 20;
  double std_weight_velocity = 1.0 / 160;
  // Floors of those noises in pixels (position) and pixels per update (velocity): between
  // keyframes a hand-held camera shifts every box by tens of pixels, whatever its size.
  // Defaults 2 px and 4 px.
  double min_position_std_px = 2.0;
  double min_velocity_std_px = 4.0;
  AppearanceOptions appearance;

  static StatusOr<TrackerOptions> FromYaml(const YAML::Node& node);
  Status Validate() const;
};

struct Track {
  enum class State { kTentative, kConfirmed };
  int64_t id = 0;  // 0 until confirmed; then unique, monotonic, >= 1
  int class_id = -1;
  std::string class_name{};
  State state = State::kTentative;
  int hits = 0;               // matched updates
  int age = 0;                // updates since creation
  int time_since_update = 0;  // updates since the last match (0 = matched this update)
  KalmanBoxFilter kf;
  cv::Mat feature{};        // appearance histogram (EMA); empty without images
  int64_t internal_id = 0;  // unique for every track, tentative ones included
};

class MultiObjectTracker {
 public:
  explicit MultiObjectTracker(TrackerOptions options = {});

  // One step (a keyframe): predicts every track, associates `detections`, updates, creates
  // and deletes tracks, and sets each detection's track_id (0 while its track is tentative).
  // `bgr` (CV_8UC3, the image of the detections) feeds the appearance cue; empty = motion only.
  void Update(const cv::Mat& bgr, std::vector<Detection2D>* detections);

  const std::vector<Track>& tracks() const { return tracks_; }
  int64_t num_confirmed_ids() const { return next_id_ - 1; }
  void Reset();

 private:
  // Matches tracks[track_idx] to detections[det_idx] minimising `cost` (forbidden >= 1e9);
  // appends pairs and removes matched entries from the index lists.
  template <typename CostFn>
  void Match(const std::vector<int>& track_idx, std::vector<int>* det_idx, CostFn cost,
             std::vector<std::pair<int, int>>* matches);

  // One update's detections with what association needs of them and of the tracks.
  struct Frame {
    const std::vector<Detection2D>* dets = nullptr;
    std::vector<cv::Rect2f> predicted;  // each track's predicted box
    std::vector<cv::Mat> features;      // each detection's appearance (empty without images)
    bool use_appearance = false;
  };
  // Cost of track ti for detection di in the matching cascade (motion, appearance; gated).
  double CascadeCost(const Frame& f, int ti, int di) const;
  // ... in the IoU stage (1 - IoU, else 1 + the cascade cost).
  double IouCost(const Frame& f, int ti, int di) const;
  // Both stages: appends (track, detection) pairs, marks matched tracks, leaves the unmatched
  // detections in unmatched_dets.
  void Associate(const Frame& f, std::vector<int>* unmatched_dets,
                 std::vector<std::pair<int, int>>* matches, std::vector<char>* matched_track);
  // Kalman update, appearance EMA and confirmation of matched tracks; sets track_id.
  void UpdateMatched(const Frame& f, const std::vector<std::pair<int, int>>& matches,
                     std::vector<Detection2D>* dets);
  void DropStaleTracks(const std::vector<char>& matched_track);
  // New tentative (n_init <= 1: confirmed) tracks from the unmatched detections.
  void StartTracks(const Frame& f, const std::vector<int>& unmatched_dets,
                   std::vector<Detection2D>* dets);

  TrackerOptions options_;
  std::vector<Track> tracks_;
  int64_t next_id_ = 1;
  int64_t next_internal_id_ = 1;
};

}  // namespace loci::detection
