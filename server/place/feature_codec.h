// Stored form of a keyframe's features (keyframe_features.h): a compact little-endian binary
// record, to be kept per keyframe beside its other products.
//
//   "LPF1"                      4 bytes, magic and version
//   uint32 count                number of keypoints, <= kMaxStoredFeatures
//   float64 fx fy cx cy         intrinsics, px
//   int32 width height          image size, px
//   float32 level_scale         size ratio of consecutive pyramid levels
//   count x {float32 u, v; uint8 octave; 32 bytes descriptor; float32 x, y, z}   53 bytes each
//
// So 52 + 53 * count bytes: about 53 KB for 1000 keypoints.
#pragma once

#include <string>
#include <string_view>

#include "common/status.h"
#include "server/place/keyframe_features.h"

namespace loci::place {

inline constexpr uint32_t kMaxStoredFeatures = 100000;
inline constexpr size_t kFeatureHeaderBytes = 52;
inline constexpr size_t kFeatureRecordBytes = 53;

StatusOr<std::string> EncodeFeatures(const KeyframeFeatures& features);
// Checks the magic, the count against the length, the intrinsics and that every number is
// finite; InvalidArgument otherwise.
StatusOr<KeyframeFeatures> DecodeFeatures(std::string_view bytes);

}  // namespace loci::place
