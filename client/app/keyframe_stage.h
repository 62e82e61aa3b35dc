// The keyframe stage of loci-track: runs the detector + multi-object tracker on keyframes when
// one is configured, attaches object masks and hands them to a sink (MapClient::Send, or
// nothing offline).
//   - Live (default): its own thread takes keyframes from a bounded queue, so tracking keeps its
//     rate; Push blocks when the queue is full (back-pressure from the network through to the
//     tracker, never a silent drop). Which frames see which keyframe's boxes as their dynamic
//     prior then depends on timing.
//   - Synchronous: Push processes the keyframe on the caller's thread before it returns, so the
//     same input gives the same keyframes, detections and map every time (recorded data, tests,
//     benchmarks).
#pragma once

#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "client/streaming/map_client.h"
#include "common/bounded_queue.h"
#include "common/detections_io.h"
#include "detection/depth_mask.h"
#include "detection/detector.h"
#include "detection/multi_object_tracker.h"

namespace loci {

// Object masks for the keyframes' detections (detection::AttachDepthMasks, with the keyframe's
// gravity when it has one): depth_scale must be the sequence's.
struct KeyframeMasking {
  detection::MaskOptions options;
  PinholeCamera camera;
};

class KeyframeStage {
 public:
  using Sink = std::function<Status(KeyframeData)>;
  // detector may be null (detections already attached, or none). capacity >= 1. With masking,
  // every detection that comes without a mask (from the detector or a file) gets one.
  // capacity 0 = synchronous.
  KeyframeStage(std::unique_ptr<detection::Detector> detector,
                std::unique_ptr<detection::MultiObjectTracker> mot, Sink sink, size_t capacity,
                std::optional<KeyframeMasking> masking = std::nullopt);
  ~KeyframeStage();

  // FailedPrecondition after Finish (the keyframe is not taken); otherwise OK (sink errors are
  // reported by Finish).
  Status Push(KeyframeData kf);
  // Processes everything queued, then stops the thread. Returns the first sink error, if any.
  Status Finish();

  // Detections of the most recently detected keyframe and its stamp (t_ns 0: none yet), for
  // the odometry's dynamic prior on the frames that follow.
  FrameDetections LatestDetections() const;

  double detect_ms_total() const { return detect_ms_total_; }
  double mask_ms_total() const { return mask_ms_total_; }
  int detected_keyframes() const { return detected_; }

 private:
  void Loop();
  void Process(KeyframeData kf);

  std::unique_ptr<detection::Detector> detector_;
  std::unique_ptr<detection::MultiObjectTracker> mot_;
  std::optional<KeyframeMasking> masking_;
  Sink sink_;
  const bool synchronous_;
  BoundedQueue<KeyframeData> queue_;  // live mode: Push -> the stage's thread
  mutable std::mutex mu_;
  FrameDetections latest_;            // guarded by mu_
  bool done_ = false;                 // guarded by mu_
  Status first_error_;
  double detect_ms_total_ = 0;
  double mask_ms_total_ = 0;
  int detected_ = 0;
  std::thread thread_;
};

}  // namespace loci
