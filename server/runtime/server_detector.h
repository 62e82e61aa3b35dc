// The server-side detection of keyframes (config section `detector`, `enabled: true`), shared by
// loci-server and `loci reprocess`.
#pragma once

#include <memory>
#include <string>

#include "common/status.h"
#include "server/detect/keyframe_detection.h"
#include "server/runtime/server_options.h"

namespace loci::server {

// Null when the config does not enable it; FailedPrecondition when it is enabled but this build
// has no detection module. config_path: the file the options came from (relative model paths).
// Makes options.detector_threads detector instances.
StatusOr<std::shared_ptr<KeyframeDetection>> MakeServerDetection(const ServerOptions& options,
                                                                  const std::string& config_path);

}  // namespace loci::server
