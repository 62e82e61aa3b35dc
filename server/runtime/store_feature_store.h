// Place-recognition features in the map database: the FeatureStore the server's
// RobotAligner keeps each keyframe's features in (place/feature_cache.h), one place_features row
// per keyframe in the stored form of place/feature_codec.h.
#pragma once

#include <string>

#include "server/place/feature_cache.h"
#include "server/storage/map_store.h"

namespace loci::server {

class StoreFeatureStore final : public place::FeatureStore {
 public:
  // `fingerprint`: FeatureOptions::Fingerprint of the features written and read.
  StoreFeatureStore(MapStore* store, std::string fingerprint)
      : store_(store), fingerprint_(std::move(fingerprint)) {}

  Status Put(int64_t keyframe_id, const place::KeyframeFeatures& features) override;
  // A stored record that does not decode is an error (DataLoss), not "none".
  StatusOr<std::optional<place::KeyframeFeatures>> Get(int64_t keyframe_id) override;

 private:
  MapStore* store_;
  std::string fingerprint_;
};

}  // namespace loci::server
