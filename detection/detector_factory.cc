#include "detection/detector_options.h"
#include "detection/file_detector.h"
#include "detection/nanodet_detector.h"
#include "detection/yolox_detector.h"

namespace loci::detection {

StatusOr<std::unique_ptr<Detector>> MakeDetector(const DetectorOptions& options) {
  LOCI_RETURN_IF_ERROR(options.Validate());
  if (options.type == "yolox") {
    LOCI_ASSIGN_OR_RETURN(auto d, YoloxDetector::Create(options));
    return std::unique_ptr<Detector>(std::move(d));
  }
  if (options.type == "nanodet") {
    LOCI_ASSIGN_OR_RETURN(auto d, NanoDetDetector::Create(options));
    return std::unique_ptr<Detector>(std::move(d));
  }
  LOCI_ASSIGN_OR_RETURN(auto d, FileDetector::Create(options));
  return std::unique_ptr<Detector>(std::move(d));
}

}  // namespace loci::detection
