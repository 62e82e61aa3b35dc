// Detector backed by a detections.jsonl file (docs/formats.md): an external or offline
// detector's output, looked up by the frame stamp (paper 000 fed files to its SLAM this way).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "detection/detector.h"
#include "detection/detector_options.h"

namespace loci::detection {

class FileDetector : public Detector {
 public:
  // Reads options.detections_path; applies the class filter and score thresholds of `options`.
  static StatusOr<std::unique_ptr<FileDetector>> Create(const DetectorOptions& options);

  // Detections of the line nearest t_ns within options.max_dt_ns (empty when none). Masks,
  // track ids and boxes are passed through as stored; `bgr` is only used to clip boxes.
  StatusOr<std::vector<Detection2D>> Detect(const cv::Mat& bgr, int64_t t_ns) override;
  std::string Name() const override { return "file:" + options_.detections_path; }

  size_t num_frames() const { return frames_.size(); }

 private:
  FileDetector(DetectorOptions options, std::vector<FrameDetections> frames);

  DetectorOptions options_;
  std::vector<FrameDetections> frames_;  // sorted by t_ns
};

}  // namespace loci::detection
