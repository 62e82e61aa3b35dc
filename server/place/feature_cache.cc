#include "server/place/feature_cache.h"

#include <absl/strings/str_cat.h>

namespace loci::place {

Status MemoryFeatureStore::Put(int64_t keyframe_id, const KeyframeFeatures& features) {
  features_[keyframe_id] = features;
  return absl::OkStatus();
}

StatusOr<std::optional<KeyframeFeatures>> MemoryFeatureStore::Get(int64_t keyframe_id) {
  auto it = features_.find(keyframe_id);
  if (it == features_.end()) return std::optional<KeyframeFeatures>();
  return std::optional<KeyframeFeatures>(it->second);
}

FeatureCache::FeatureCache(FeatureStore* store, size_t capacity)
    : store_(store), lru_(capacity) {}

Status FeatureCache::Put(int64_t keyframe_id, KeyframeFeatures features) {
  Status stored = store_->Put(keyframe_id, features);
  Keep(keyframe_id, std::move(features));
  return stored;
}

void FeatureCache::Keep(int64_t keyframe_id, KeyframeFeatures features) {
  lru_.Put(keyframe_id, std::make_shared<const KeyframeFeatures>(std::move(features)));
}

StatusOr<std::shared_ptr<const KeyframeFeatures>> FeatureCache::Get(int64_t keyframe_id) {
  if (const auto* cached = lru_.Get(keyframe_id)) {
    ++stats_.hits;
    return *cached;
  }
  LOCI_ASSIGN_OR_RETURN(std::optional<KeyframeFeatures> stored, store_->Get(keyframe_id));
  if (!stored) {
    return absl::NotFoundError(absl::StrCat("keyframe ", keyframe_id, ": no stored features"));
  }
  ++stats_.misses;
  auto features = std::make_shared<const KeyframeFeatures>(std::move(*stored));
  lru_.Put(keyframe_id, features);
  return features;
}

FeatureCacheStats FeatureCache::Stats() const {
  FeatureCacheStats s = stats_;
  s.cached = lru_.size();
  return s;
}

}  // namespace loci::place
