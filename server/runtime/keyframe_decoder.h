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
  int max_detections = 512;        // detections per keyframe
  int max_image_px = 4096;         // width and height, px
  double map_extent_m = 10'000.0;  // |x|, |y|, |z| of T_base_kf, m
  // t_ns must lie in [2000-01-01, now + max_future_ns].
  int64_t max_future_ns = 86'400'000'000'000;  // one day
};

// Earliest accepted keyframe stamp: 2000-01-01T00:00:00Z.
inline constexpr int64_t kMinKeyframeTNs = 946'684'800'000'000'000;

// Checks a keyframe of `session` and converts it to a record (images still compressed): the
// pose (finite, unit quaternion, T_base_kf inside the map extent), the stamp (see
// ValidationLimits), intrinsics, gravity, and both images, whose headers are checked before
// they are decoded. `decoded` (optional) receives the mapper input.
StatusOr<KeyframeRecord> ValidateKeyframe(const loci::v1::Keyframe& kf,
                                          const SessionRecord& session,
                                          const ValidationLimits& limits, MapperKeyframe* decoded);

// The mapper input of a stored keyframe without its images (pose, camera, gravity), for one
// mapped from its products; T_base_kf is BaseFromKeyframe (the corrected pose when stored).
MapperKeyframe KeyframeMeta(const KeyframeRecord& record, const SessionRecord& session);

// A stored keyframe's images, decoded: BGR and depth in metres (0 = no reading).
struct StoredImages {
  cv::Mat bgr;
  cv::Mat depth_m;
};
StatusOr<StoredImages> DecodeStoredImages(const KeyframeRecord& record);

// Decodes a stored keyframe for the mapper: KeyframeMeta plus the images and detections.
StatusOr<MapperKeyframe> DecodeKeyframe(const KeyframeRecord& record, const SessionRecord& session);

}  // namespace loci::server
