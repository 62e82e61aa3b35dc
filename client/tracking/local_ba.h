// Windowed local bundle adjustment (Ceres): the newest keyframes' poses and the points they
// observe are refined over every window keyframe that observes those points (older keyframes
// held fixed), with the same residuals as the pose refinement (reprojection + virtual stereo
// depth, Huber). Run after each new keyframe; bounded by iterations and solver time.
#pragma once

#include "client/tracking/local_map.h"
#include "common/camera.h"

namespace loci {

struct LocalBaOptions {
  int num_optimised_keyframes = 5;  // newest keyframes whose poses move
  int max_iterations = 5;           // Levenberg-Marquardt iterations
  double max_time_s = 0.03;         // solver wall-time cap (s)
  double bf_px = 41.4;              // fx * virtual baseline (px)
};

// Returns false when there was nothing to optimise or the solver failed (map unchanged).
bool LocalBundleAdjust(const PinholeCamera& cam, const LocalBaOptions& opt,
                       const std::vector<float>& level_inv_sigma2, LocalMap* map);

}  // namespace loci
