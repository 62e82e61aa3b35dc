// A real detector's errors on a synthetic sequence's exact detections (SceneOptions::
// detector_noise): boxes jittered, objects missed (small ones more often), false boxes of
// random classes, look-alike classes confused, scores below 1, and tracks that break. Masks are
// dropped: the server segments each box from depth, as for a robot that sends none.
#pragma once

#include <cstdint>
#include <vector>

#include "common/detections_io.h"

namespace loci::synth {

struct DetectorNoise {
  double box_jitter_rel = 0.05;      // sigma of each box edge, share of the box's side
  double miss_p = 0.2;               // per object and frame
  double small_miss_p = 0.5;         // ... for boxes with a side below small_px
  double small_px = 40;
  double false_boxes_per_frame = 0.15;
  double confusion_p = 0.05;         // a look-alike class instead (tv/laptop, cup/bottle, ...)
  float min_score = 0.35f, max_score = 0.95f;
  double track_break_p = 0.01;       // per object and frame: the tracker starts a new id
};

// Applies `noise` to every frame in order (deterministic for `seed`); image size for the false
// boxes. Track ids stay unique: object id + 1000 x the number of breaks so far.
void ApplyDetectorNoise(const DetectorNoise& noise, uint64_t seed, int width_px, int height_px,
                        std::vector<FrameDetections>* frames);

}  // namespace loci::synth
