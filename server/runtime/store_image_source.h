// Keyframe images read back from the map database for the dense refinement of place matches
// (place/dense_refinement.h): a candidate keyframe whose reduced images have left the aligner's
// cache, an old keyframe or one stored before a restart, is read and decoded again (about 7 ms
// of CPU on a real TUM sequence).
#pragma once

#include "server/place/dense_refinement.h"
#include "server/storage/map_store.h"

namespace loci::server {

class StoreImageSource final : public place::KeyframeImageSource {
 public:
  explicit StoreImageSource(MapStore* store) : store_(store) {}

  // nullopt for an unknown keyframe or one whose images retention dropped; DataLoss when the
  // stored images do not decode.
  StatusOr<std::optional<place::KeyframeImages>> Read(int64_t keyframe_id) override;

 private:
  MapStore* store_;
};

}  // namespace loci::server
