// The object map on one varied synthetic room (`loci synth --varied --det-noise`): the scene is
// rendered into a folder, mapped by the demo's pipeline (cli/report/report_pipeline.h) from its
// noisy detections, and scored against its true objects (mapped, non-dynamic classes; objects
// a perfect detector boxes in fewer than 10 frames neither count nor penalise). Shared by
// `loci bench objects` and the test suite.
#pragma once

#include <cstdint>
#include <string>

#include "common/status.h"
#include "server/map/object_eval.h"

namespace loci::report {

struct SynthObjectsOptions {
  uint64_t seed = 1;
  int frames = 200;
  int max_objects = 14;        // the layout draws between 6 and this many
  bool detector_noise = true;  // synth/detector_noise.h; false: exact boxes and masks
  std::string work_dir;        // the sequence is written to work_dir/seed-N (created)
  std::string server_config;   // "" = config/server.yaml
};

struct SynthObjectsResult {
  uint64_t seed = 0;
  server::ObjectEvalResult eval;
  double seconds = 0;  // render + map + evaluate
};

StatusOr<SynthObjectsResult> EvaluateSynthObjects(const SynthObjectsOptions& options);

}  // namespace loci::report
