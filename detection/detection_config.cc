#include "detection/detection_config.h"

#include "common/config.h"

namespace loci::detection {

StatusOr<DetectionConfig> LoadDetectionConfig(const std::string& path,
                                              const std::string& base_dir) {
  LOCI_ASSIGN_OR_RETURN(YAML::Node root, LoadYamlFile(path));
  const ConfigFileScope scope(path);
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(root, "", {"detector", "mask", "tracker"}));
  DetectionConfig c;
  LOCI_ASSIGN_OR_RETURN(c.detector, DetectorOptions::FromYaml(root["detector"], base_dir));
  LOCI_ASSIGN_OR_RETURN(c.mask, MaskOptions::FromYaml(root["mask"]));
  LOCI_ASSIGN_OR_RETURN(c.tracker, TrackerOptions::FromYaml(root["tracker"]));
  return c;
}

std::string DefaultDetectionConfigPath() { return SourceDir() + "/config/detection.yaml"; }

}  // namespace loci::detection
