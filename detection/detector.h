// Object detector interface, used by the tracking client (on keyframes, in its own thread) and
// by the server (keyframes that arrive without detections).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "common/detections_io.h"
#include "common/status.h"

namespace loci::detection {

class Detector {
 public:
  virtual ~Detector() = default;
  // Detections in `bgr` (CV_8UC3) taken at t_ns, boxes in pixels of `bgr`, filtered by the
  // configured class list and per-class score thresholds. track_id stays 0 (the tracker sets it).
  // A file-backed detector looks the frame up by t_ns.
  virtual StatusOr<std::vector<Detection2D>> Detect(const cv::Mat& bgr, int64_t t_ns) = 0;
  // e.g. "yolox_nano", "nanodet_m", "file:detections.jsonl"
  virtual std::string Name() const = 0;
};

}  // namespace loci::detection
