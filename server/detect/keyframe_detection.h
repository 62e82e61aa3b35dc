// Server-side detection of keyframes (config section `detector`), ahead of the map worker.
//   mode "missing": only keyframes that arrive without detections are detected; a robot's own
//     boxes are kept otherwise.
//   mode "all": every keyframe is detected again with the server's model (a larger one than a
//     robot can run); the robot's boxes are the fallback when the server's detector fails.
// A server box has no track: it inherits the track of the same-class robot box it overlaps most
// (IoU at least inherit_track_iou), so the map's track term still joins a robot's views.
// Detection runs on its own threads, one detector instance per thread: Prefetch starts a queued
// keyframe's detection while the map worker is busy with earlier ones; Apply takes the result
// (or detects then, for keyframes never prefetched, as on replay).
#pragma once

#include <atomic>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "common/bounded_queue.h"
#include "common/status.h"
#include "common/task_pool.h"
#include "detection/detector.h"
#include "server/map/mapper.h"

namespace loci::server {

enum class DetectMode { kMissing, kAll };

// "missing" | "all"; InvalidArgument otherwise.
StatusOr<DetectMode> ParseDetectMode(const std::string& name);

struct KeyframeDetectionOptions {
  DetectMode mode = DetectMode::kMissing;
  double inherit_track_iou = 0.5;
  int max_prefetched = 16;  // keyframes detected ahead at most; later ones are detected by Apply
};

class KeyframeDetection {
 public:
  // One thread per detector; at least one detector.
  KeyframeDetection(std::vector<std::shared_ptr<detection::Detector>> detectors,
                    KeyframeDetectionOptions options);
  ~KeyframeDetection();
  KeyframeDetection(const KeyframeDetection&) = delete;
  KeyframeDetection& operator=(const KeyframeDetection&) = delete;

  // Starts detecting `kf` (by keyframe_id) when the mode wants it and fewer than
  // max_prefetched wait. The images are shared, not copied; they are only read.
  void Prefetch(const MapperKeyframe& kf);
  // Gives `kf` the detections the mode wants. On a detector error the keyframe keeps the
  // robot's boxes and the error is returned (for the log).
  Status Apply(MapperKeyframe* kf);
  // "<mode>:<detector name>"; keyframes detected and detector failures since start.
  std::string Name() const;
  int64_t detected() const { return detected_; }
  int64_t failed() const { return failed_; }

 private:
  using Result = StatusOr<std::vector<Detection2D>>;
  bool Wants(const MapperKeyframe& kf) const;
  Result Run(const cv::Mat& bgr, int64_t t_ns);
  std::future<Result> TakePrefetched(int64_t keyframe_id);

  const KeyframeDetectionOptions options_;
  const std::string name_;
  // Idle detectors: a detection takes one and gives it back.
  BoundedQueue<std::shared_ptr<detection::Detector>> idle_;
  std::mutex mu_;  // guards prefetched_
  std::map<int64_t, std::future<Result>> prefetched_;
  std::atomic<int64_t> detected_{0}, failed_{0};
  TaskPool pool_;  // last: joined first, while the members its tasks use still exist
};

// Each server box (track 0) takes the track id of the same-class robot box it overlaps most,
// when that IoU is at least min_iou.
void InheritTracks(const std::vector<Detection2D>& robot, double min_iou,
                   std::vector<Detection2D>* server);

}  // namespace loci::server
