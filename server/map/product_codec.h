// Per-keyframe products <-> their stored form (loci.store.v1.KeyframeProducts, keyframe frame):
// what a restart or a pose change re-derives the map from, without the images. Lossless: a
// decoded product maps exactly as the one that was encoded.
#pragma once

#include <string>

#include "common/status.h"
#include "server/map/keyframe_products.h"

namespace loci::server {

std::string EncodeProducts(const KeyframeProducts& products, const std::string& fingerprint);

// DataLoss for bytes that do not parse; FailedPrecondition when the stored fingerprint is not
// `fingerprint` (products made with other options: recompute them).
// with_visibility false skips the visibility depth and detection boxes (a pose update needs only
// the points).
StatusOr<KeyframeProducts> DecodeProducts(const std::string& bytes, const std::string& fingerprint,
                                          bool with_visibility = true);

}  // namespace loci::server
