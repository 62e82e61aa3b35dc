// config/detection.yaml as one struct: detector, mask and tracker options.
#pragma once

#include <string>

#include "common/status.h"
#include "detection/depth_mask.h"
#include "detection/detector_options.h"
#include "detection/multi_object_tracker.h"

namespace loci::detection {

struct DetectionConfig {
  DetectorOptions detector;
  MaskOptions mask;
  TrackerOptions tracker;
};

// Reads the `detector`, `mask` and `tracker` maps of `path` (absent maps keep defaults).
// Relative paths inside are resolved against base_dir (empty = the repository root).
StatusOr<DetectionConfig> LoadDetectionConfig(const std::string& path,
                                              const std::string& base_dir = "");

// The shipped config/detection.yaml.
std::string DefaultDetectionConfigPath();

}  // namespace loci::detection
