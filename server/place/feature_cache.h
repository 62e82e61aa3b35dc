// Keyframe features out of memory: a keyframe's features take about 60 KB, so a map
// cannot keep every keyframe's in memory. Each keyframe's features are written once to a
// FeatureStore (the map database on the server, server/runtime/store_feature_store.h) and the
// most recently used ones stay in a FeatureCache of fixed size; geometric verification reads the
// few candidates it needs through it.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <unordered_map>

#include "common/lru_cache.h"
#include "common/status.h"
#include "server/place/keyframe_features.h"

namespace loci::place {

// Where features live when they are not in the cache.
class FeatureStore {
 public:
  virtual ~FeatureStore() = default;
  virtual Status Put(int64_t keyframe_id, const KeyframeFeatures& features) = 0;
  // nullopt when the keyframe has no stored features.
  virtual StatusOr<std::optional<KeyframeFeatures>> Get(int64_t keyframe_id) = 0;
};

// Every keyframe's features in memory: for tests, benchmarks and maps without a database.
class MemoryFeatureStore final : public FeatureStore {
 public:
  Status Put(int64_t keyframe_id, const KeyframeFeatures& features) override;
  StatusOr<std::optional<KeyframeFeatures>> Get(int64_t keyframe_id) override;

 private:
  std::unordered_map<int64_t, KeyframeFeatures> features_;
};

struct FeatureCacheStats {
  uint64_t hits = 0;
  uint64_t misses = 0;  // read back from the store
  size_t cached = 0;    // keyframes in memory now
};

// Least-recently-used cache in front of a FeatureStore. Not thread-safe (RobotAligner calls it
// under its work lock). Handed-out features stay valid after they are evicted.
class FeatureCache {
 public:
  // capacity >= 1 keyframes; `store` outlives the cache.
  FeatureCache(FeatureStore* store, size_t capacity);

  // Stores the keyframe's features (write-through) and caches them; they are cached even when
  // the store fails (the status says so).
  Status Put(int64_t keyframe_id, KeyframeFeatures features);
  // Caches features read from the store elsewhere (re-indexing after a restart); no write.
  void Keep(int64_t keyframe_id, KeyframeFeatures features);
  // NotFound when neither the cache nor the store has them.
  StatusOr<std::shared_ptr<const KeyframeFeatures>> Get(int64_t keyframe_id);
  FeatureCacheStats Stats() const;

 private:
  FeatureStore* store_;
  LruCache<int64_t, std::shared_ptr<const KeyframeFeatures>> lru_;
  FeatureCacheStats stats_;
};

}  // namespace loci::place
