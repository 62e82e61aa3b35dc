// Validation of incoming keyframes and decoding of stored ones into mapper input.
// Every check returns InvalidArgument with a message naming the field; nothing is stored or
// changed by a failed check.
#pragma once

#include "common/status.h"
#include "loci/v1/mapping.pb.h"
#include "server/map/mapper.h"
#include "server/storage/map_store.h"

namespace loci::server {

struct ValidationLimits {
  int max_detections = 512;  // detections per keyframe
  int max_image_px = 4096;   // width and height, px
};

// Checks a keyframe of `session` and converts it to a record (images still compressed).
// Decodes both images to verify them; `decoded` (optional) receives the mapper input.
StatusOr<KeyframeRecord> ValidateKeyframe(const loci::v1::Keyframe& kf,
                                          const SessionRecord& session,
                                          const ValidationLimits& limits, MapperKeyframe* decoded);

// Decodes a stored keyframe for the mapper; T_base_kf = session.T_base_odom * T_odom_cam.
StatusOr<MapperKeyframe> DecodeKeyframe(const KeyframeRecord& record, const SessionRecord& session);

}  // namespace loci::server
