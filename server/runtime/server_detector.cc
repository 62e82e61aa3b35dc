#include "server/runtime/server_detector.h"

#include <spdlog/spdlog.h>

#include "common/config.h"
#ifdef LOCI_HAVE_DETECTION
#include "detection/detector_options.h"
#endif

namespace loci::server {

StatusOr<std::shared_ptr<KeyframeDetection>> MakeServerDetection(const ServerOptions& options,
                                                                  const std::string& config_path) {
  if (!options.detector_enabled) return std::shared_ptr<KeyframeDetection>();
#ifdef LOCI_HAVE_DETECTION
  const ConfigFileScope scope(config_path);
  LOCI_ASSIGN_OR_RETURN(auto det_options,
                        detection::DetectorOptions::FromYaml(options.detector_config, SourceDir()));
  KeyframeDetectionOptions kd;
  LOCI_ASSIGN_OR_RETURN(kd.mode, ParseDetectMode(options.detector_mode));
  std::vector<std::shared_ptr<detection::Detector>> detectors;
  for (int i = 0; i < options.detector_threads; ++i) {
    LOCI_ASSIGN_OR_RETURN(auto detector, detection::MakeDetector(det_options));
    detectors.push_back(std::move(detector));
  }
  auto detection = std::make_shared<KeyframeDetection>(std::move(detectors), kd);
  spdlog::info("server-side detection: {} on {} thread(s)", detection->Name(),
               options.detector_threads);
  return detection;
#else
  (void)config_path;
  return absl::FailedPreconditionError(
      "detector.enabled is set but loci-server was built without the detection module");
#endif
}

}  // namespace loci::server
