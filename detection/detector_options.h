// Options shared by every Detector implementation and the factory that builds one from them.
#pragma once

#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "common/status.h"
#include "detection/detector.h"

namespace loci::detection {

struct DetectorOptions {
  // "yolox" (YOLOX ONNX), "nanodet" (NanoDet-m ONNX) or "file" (detections.jsonl).
  std::string type = "yolox";
  // ONNX model file. Relative paths in YAML are resolved against the base directory given to
  // FromYaml (the repository root by default). Default: the shipped YOLOX-Nano.
  std::string model_path = "models/yolox_nano/yolox_nano.onnx";
  // Class names, one per line, line i = class index i. Empty = coco80.names next to the model.
  std::string class_names_path;
  // Square network input side, pixels. Must match the model (YOLOX-Nano 416, NanoDet-m 320).
  int input_size_px = 416;
  // OpenCV worker threads (cv::setNumThreads, process-wide). 0 = leave OpenCV's default.
  int num_threads = 0;
  // Minimum score [0, 1] for classes without an entry in class_score_thresholds. Default 0.3.
  float score_threshold = 0.3f;
  // Per-class minimum score by class name, overriding score_threshold.
  std::map<std::string, float> class_score_thresholds;
  // Class names kept (the "mapped" list of config/classes.yaml by default in detection.yaml);
  // empty = keep every class.
  std::vector<std::string> classes;
  // IoU above which a lower-scoring box of the same class is suppressed. Default 0.45.
  float nms_iou = 0.45f;
  // For type "file": detections.jsonl; lines are matched to frames by nearest t_ns.
  std::string detections_path;
  // For type "file": largest stamp difference accepted when matching a frame, ns. Default 20 ms.
  int64_t max_dt_ns = 20'000'000;

  // Fills the keys present in `node` (the `detector:` map of config/detection.yaml). Paths are
  // resolved against base_dir (empty = SourceDir()). `classes_file: F` loads F's `mapped` list
  // unless `classes: [...]` is given.
  static StatusOr<DetectorOptions> FromYaml(const YAML::Node& node,
                                            const std::string& base_dir = "");
  Status Validate() const;
  // Score threshold for class `name`.
  float ThresholdFor(const std::string& name) const;
  // True when `name` passes the class filter.
  bool Keeps(const std::string& name) const;
};

// Builds the detector `options.type` names. Errors (never crashes) on a missing or corrupt
// model, unreadable class list or detections file.
StatusOr<std::unique_ptr<Detector>> MakeDetector(const DetectorOptions& options);

// Reads class names, one per line (trailing whitespace trimmed); error when missing or empty.
StatusOr<std::vector<std::string>> ReadClassNames(const std::string& path);

}  // namespace loci::detection
