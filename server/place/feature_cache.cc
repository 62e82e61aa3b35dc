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
    : store_(store), capacity_(capacity < 1 ? 1 : capacity) {}

Status FeatureCache::Put(int64_t keyframe_id, KeyframeFeatures features) {
  Status stored = store_->Put(keyframe_id, features);
  Keep(keyframe_id, std::move(features));
  return stored;
}

void FeatureCache::Keep(int64_t keyframe_id, KeyframeFeatures features) {
  Insert(keyframe_id, std::make_shared<const KeyframeFeatures>(std::move(features)));
}

void FeatureCache::Insert(int64_t keyframe_id, std::shared_ptr<const KeyframeFeatures> features) {
  auto it = index_.find(keyframe_id);
  if (it != index_.end()) {
    lru_.erase(it->second);
    index_.erase(it);
  }
  lru_.emplace_front(keyframe_id, std::move(features));
  index_[keyframe_id] = lru_.begin();
  while (lru_.size() > capacity_) {
    index_.erase(lru_.back().first);
    lru_.pop_back();
  }
}

StatusOr<std::shared_ptr<const KeyframeFeatures>> FeatureCache::Get(int64_t keyframe_id) {
  auto it = index_.find(keyframe_id);
  if (it != index_.end()) {
    ++stats_.hits;
    lru_.splice(lru_.begin(), lru_, it->second);  // most recent now
    return lru_.front().second;
  }
  LOCI_ASSIGN_OR_RETURN(std::optional<KeyframeFeatures> stored, store_->Get(keyframe_id));
  if (!stored) {
    return absl::NotFoundError(absl::StrCat("keyframe ", keyframe_id, ": no stored features"));
  }
  ++stats_.misses;
  auto features = std::make_shared<const KeyframeFeatures>(std::move(*stored));
  Insert(keyframe_id, features);
  return features;
}

FeatureCacheStats FeatureCache::Stats() const {
  FeatureCacheStats s = stats_;
  s.cached = lru_.size();
  return s;
}

}  // namespace loci::place
