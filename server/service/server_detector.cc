#include "server/service/server_detector.h"

#include <spdlog/spdlog.h>

#include "common/config.h"
#ifdef LOCI_HAVE_DETECTION
#include "detection/detector_options.h"
#endif

namespace loci::server {

StatusOr<std::shared_ptr<detection::Detector>> MakeServerDetector(const ServerOptions& options,
                                                                  const std::string& config_path) {
  if (!options.detector_enabled) return std::shared_ptr<detection::Detector>();
#ifdef LOCI_HAVE_DETECTION
  const ConfigFileScope scope(config_path);
  LOCI_ASSIGN_OR_RETURN(auto det_options,
                        detection::DetectorOptions::FromYaml(options.detector_config, SourceDir()));
  LOCI_ASSIGN_OR_RETURN(auto detector, detection::MakeDetector(det_options));
  spdlog::info("server-side detector: {}", detector->Name());
  return std::shared_ptr<detection::Detector>(std::move(detector));
#else
  (void)config_path;
  return absl::FailedPreconditionError(
      "detector.enabled is set but loci-server was built without the detection module");
#endif
}

}  // namespace loci::server
