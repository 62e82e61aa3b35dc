#include "server/runtime/store_feature_store.h"

#include "server/place/feature_codec.h"

namespace loci::server {

Status StoreFeatureStore::Put(int64_t keyframe_id, const place::KeyframeFeatures& features) {
  LOCI_ASSIGN_OR_RETURN(const std::string bytes, place::EncodeFeatures(features));
  return store_->PutPlaceFeatures(keyframe_id, fingerprint_, bytes);
}

StatusOr<std::optional<place::KeyframeFeatures>> StoreFeatureStore::Get(int64_t keyframe_id) {
  LOCI_ASSIGN_OR_RETURN(std::optional<std::string> bytes,
                        store_->GetPlaceFeatures(keyframe_id, fingerprint_));
  if (!bytes) return std::optional<place::KeyframeFeatures>();
  StatusOr<place::KeyframeFeatures> features = place::DecodeFeatures(*bytes);
  if (!features.ok()) {
    return absl::DataLossError(absl::StrCat("keyframe ", keyframe_id, ": stored features: ",
                                            features.status().message()));
  }
  return std::optional<place::KeyframeFeatures>(std::move(*features));
}

}  // namespace loci::server
