// The map over three sessions of one varied synthetic room, two days apart (`loci synth
// --moved / --absent / --days-later`): session 1 maps the room without one object C; in session
// 2 object A was put elsewhere and B taken away; in session 3 C is there and D was put
// elsewhere. Each session is mapped into the same map from its noisy detections with the
// scene's poses, and the changes the map reports in sessions 2 and 3 (MOVED and REMOVED events
// of confirmed objects, newly confirmed objects) are scored against the true ones. Changes of
// objects a perfect detector barely boxes ("low" in objects.json) neither count nor penalise.
// Shared by `loci bench changes` and the test suite.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/status.h"

namespace loci::report {

struct SynthChangesOptions {
  uint64_t seed = 1;
  int frames = 200;            // per session
  int every_nth = 5;           // frames mapped: every n-th (6 Hz at 30 Hz)
  int max_objects = 14;        // the layout draws between 6 and this many
  bool detector_noise = true;  // synth/detector_noise.h; false: exact boxes and masks
  std::string work_dir;        // sessions written to work_dir/seed-N/session-K (created)
  std::string server_config;   // "" = config/server.yaml
};

struct SynthChangesResult {
  uint64_t seed = 0;
  int objects = 0;       // evaluated objects of the room
  int true_changes = 0;  // in sessions 2 and 3 (at most 4)
  int found = 0;         // of them reported, of the right kind, at the right place
  int false_changes = 0;  // reported changes that did not happen
  // True changes left out because no keyframe of the session showed the old place (a map
  // cannot tell a place is empty that it never saw); they count neither way.
  int unobservable = 0;
  double seconds = 0;     // render + map + evaluate
  // One line per missed or false change: "session 2: missed moved cup from (..) to (..)".
  std::vector<std::string> notes;
};

StatusOr<SynthChangesResult> EvaluateSynthChanges(const SynthChangesOptions& options);

}  // namespace loci::report
