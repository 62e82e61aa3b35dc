// Rebuilds a map from stored keyframes (server restart, offline export and evaluation): the
// map products are a pure function of the stored keyframes, replayed in id order.
#pragma once

#include <cstdint>

#include "common/status.h"
#include "detection/detector.h"
#include "server/map/mapper.h"
#include "server/storage/map_store.h"

namespace loci::server {

// Runs the detector on keyframes stored without detections (when `detector` is non-null).
Status DetectIfNeeded(detection::Detector* detector, MapperKeyframe* keyframe);

// Integrates every stored keyframe with id > after_id into `mapper`; returns the last id seen
// (after_id when none) and counts them in *count.
StatusOr<int64_t> ReplayStore(MapStore& store, Mapper& mapper, detection::Detector* detector,
                              int64_t after_id = 0, uint64_t* count = nullptr);

}  // namespace loci::server
