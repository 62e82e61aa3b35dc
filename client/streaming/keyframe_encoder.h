// Keyframe -> loci.v1.Keyframe: RGB as JPEG, depth as 16-bit PNG (common/image_codec.h), pose,
// gravity and detections (masks as 8-bit PNG).
#pragma once

#include "client/streaming/map_client.h"
#include "common/status.h"
#include "loci/v1/mapping.pb.h"

namespace loci {

StatusOr<v1::Keyframe> EncodeKeyframe(const KeyframeData& kf, int64_t seq, int jpeg_quality);

}  // namespace loci
