#include "client/app/keyframe_stage.h"

#include <spdlog/spdlog.h>

#include <chrono>

#include "common/thread_name.h"

namespace loci {

KeyframeStage::KeyframeStage(std::unique_ptr<detection::Detector> detector,
                             std::unique_ptr<detection::MultiObjectTracker> mot, Sink sink,
                             size_t capacity, std::optional<KeyframeMasking> masking)
    : detector_(std::move(detector)),
      mot_(std::move(mot)),
      masking_(std::move(masking)),
      sink_(std::move(sink)),
      synchronous_(capacity == 0),
      queue_(capacity) {
  if (!synchronous_) thread_ = NamedThread("track-keyframes", [this] { Loop(); });
}

KeyframeStage::~KeyframeStage() { (void)Finish(); }

Status KeyframeStage::Push(KeyframeData kf) {
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (done_) return absl::FailedPreconditionError("keyframe stage already finished");
  }
  if (synchronous_) {
    Process(std::move(kf));
    return absl::OkStatus();
  }
  // Blocks while the queue is full; false once Finish closed it (the keyframe is not taken).
  if (!queue_.Push(std::move(kf))) {
    return absl::FailedPreconditionError("keyframe stage finished while waiting");
  }
  return absl::OkStatus();
}

Status KeyframeStage::Finish() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    done_ = true;
  }
  queue_.Close();  // the thread drains what is queued, then ends
  if (thread_.joinable()) thread_.join();
  return first_error_;
}

FrameDetections KeyframeStage::LatestDetections() const {
  std::lock_guard<std::mutex> lock(mu_);
  return latest_;
}

void KeyframeStage::Loop() {
  while (std::optional<KeyframeData> kf = queue_.Pop()) Process(std::move(*kf));
}

void KeyframeStage::Process(KeyframeData kf) {
  if (detector_) {
    const auto t0 = std::chrono::steady_clock::now();
    auto dets = detector_->Detect(kf.bgr, kf.t_ns);
    if (dets.ok()) {
      kf.detections = std::move(*dets);
      if (mot_) mot_->Update(kf.bgr, &kf.detections);
      std::lock_guard<std::mutex> lock(mu_);
      latest_.t_ns = kf.t_ns;
      latest_.detections = kf.detections;
    } else {
      spdlog::warn("detector {}: {}", detector_->Name(), std::string(dets.status().message()));
    }
    detect_ms_total_ +=
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    ++detected_;
  }
  if (masking_ && !kf.detections.empty() && !kf.depth_u16.empty()) {
    const auto t0 = std::chrono::steady_clock::now();
    detection::AttachDepthMasks(kf.depth_u16, &kf.detections, masking_->options, masking_->camera,
                                kf.gravity_cam);
    mask_ms_total_ +=
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  }
  if (sink_) {
    Status s = sink_(std::move(kf));
    if (!s.ok() && first_error_.ok()) first_error_ = s;
  }
}

}  // namespace loci
