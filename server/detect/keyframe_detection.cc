#include "server/detect/keyframe_detection.h"

#include <spdlog/spdlog.h>

#include <utility>

namespace loci::server {

StatusOr<DetectMode> ParseDetectMode(const std::string& name) {
  if (name == "missing") return DetectMode::kMissing;
  if (name == "all") return DetectMode::kAll;
  return absl::InvalidArgumentError(
      absl::StrCat("detector mode must be \"missing\" or \"all\", not \"", name, "\""));
}

KeyframeDetection::KeyframeDetection(std::vector<std::shared_ptr<detection::Detector>> detectors,
                                     KeyframeDetectionOptions options)
    : options_(options),
      name_(absl::StrCat(options.mode == DetectMode::kAll ? "all" : "missing", ":",
                         detectors.at(0)->Name())),
      idle_(detectors.size()),
      pool_(detectors.size()) {
  for (auto& d : detectors) idle_.Push(std::move(d));
}

KeyframeDetection::~KeyframeDetection() = default;

std::string KeyframeDetection::Name() const { return name_; }

bool KeyframeDetection::Wants(const MapperKeyframe& kf) const {
  return !kf.bgr.empty() && (options_.mode == DetectMode::kAll || kf.detections.empty());
}

KeyframeDetection::Result KeyframeDetection::Run(const cv::Mat& bgr, int64_t t_ns) {
  std::optional<std::shared_ptr<detection::Detector>> detector = idle_.Pop();
  if (!detector) return absl::CancelledError("server detector shut down");
  Result result = absl::InternalError("server detector threw");
  try {
    result = (*detector)->Detect(bgr, t_ns);
  } catch (const std::exception& e) {
    result = absl::InternalError(absl::StrCat("server detector threw: ", e.what()));
  }
  idle_.Push(std::move(*detector));
  return result;
}

void KeyframeDetection::Prefetch(const MapperKeyframe& kf) {
  if (!Wants(kf)) return;
  std::lock_guard<std::mutex> lock(mu_);
  if (prefetched_.size() >= static_cast<size_t>(options_.max_prefetched)) return;
  if (prefetched_.count(kf.keyframe_id)) return;
  prefetched_[kf.keyframe_id] =
      pool_.Submit([this, bgr = kf.bgr, t_ns = kf.t_ns] { return Run(bgr, t_ns); });
}

std::future<KeyframeDetection::Result> KeyframeDetection::TakePrefetched(int64_t keyframe_id) {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = prefetched_.find(keyframe_id);
  if (it == prefetched_.end()) return {};
  std::future<Result> f = std::move(it->second);
  prefetched_.erase(it);
  return f;
}

Status KeyframeDetection::Apply(MapperKeyframe* kf) {
  std::future<Result> prefetched = TakePrefetched(kf->keyframe_id);
  if (!Wants(*kf)) return absl::OkStatus();
  Result result = prefetched.valid() ? prefetched.get() : Run(kf->bgr, kf->t_ns);
  if (!result.ok()) {
    ++failed_;
    return result.status();
  }
  ++detected_;
  InheritTracks(kf->detections, options_.inherit_track_iou, &*result);
  kf->detections = *std::move(result);
  return absl::OkStatus();
}

void InheritTracks(const std::vector<Detection2D>& robot, double min_iou,
                   std::vector<Detection2D>* server) {
  for (Detection2D& s : *server) {
    if (s.track_id != 0) continue;
    double best = min_iou;
    for (const Detection2D& r : robot) {
      if (r.track_id == 0 || r.class_name != s.class_name) continue;
      const double iou = BoxIou(r.box_px, s.box_px);
      if (iou >= best) {
        best = iou;
        s.track_id = r.track_id;
      }
    }
  }
}

}  // namespace loci::server
