// Test-side streamer: turns a TUM-layout folder written by `loci synth` (images, groundtruth
// poses, detections.jsonl, accelerometer) into protocol v1 keyframes, as a client would send;
// a real TUM recording without detections.jsonl gives keyframes without boxes.
#pragma once

#include <string>
#include <vector>

#include "common/camera.h"
#include "common/status.h"
#include "loci/v1/mapping.pb.h"

namespace loci::server::testing {

// Keyframes of every `every_nth` frame (seq = 0, 1, ...), session id left empty. Poses are the
// ground truth (T_odom_cam = T_world_cam), gravity from accelerometer.txt when present.
StatusOr<std::vector<loci::v1::Keyframe>> LoadSceneKeyframes(const std::string& dir,
                                                             int every_nth = 1);

}  // namespace loci::server::testing
