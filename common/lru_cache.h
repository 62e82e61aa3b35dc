// loci::LruCache: a fixed number of values by key, the least recently used dropped first. Not
// thread-safe. Values are typically shared_ptr<const T>, so that what Get handed out stays valid
// after it is evicted.
//
//   LruCache<int64_t, std::shared_ptr<const T>> cache(256);
//   cache.Put(id, value);                      // most recent; evicts beyond the capacity
//   if (const auto* v = cache.Get(id)) use(*v);  // marks it most recent; null when absent
#pragma once

#include <cstddef>
#include <list>
#include <unordered_map>
#include <utility>

namespace loci {

template <typename Key, typename Value>
class LruCache {
 public:
  explicit LruCache(size_t capacity) : capacity_(capacity < 1 ? 1 : capacity) {}

  void Put(const Key& key, Value value) {
    if (auto it = index_.find(key); it != index_.end()) {
      lru_.erase(it->second);
      index_.erase(it);
    }
    lru_.emplace_front(key, std::move(value));
    index_[key] = lru_.begin();
    while (lru_.size() > capacity_) {
      index_.erase(lru_.back().first);
      lru_.pop_back();
    }
  }

  // Valid until the next Put.
  const Value* Get(const Key& key) {
    auto it = index_.find(key);
    if (it == index_.end()) return nullptr;
    lru_.splice(lru_.begin(), lru_, it->second);  // most recent now
    return &lru_.front().second;
  }

  size_t size() const { return lru_.size(); }

 private:
  using Entry = std::pair<Key, Value>;
  size_t capacity_;
  std::list<Entry> lru_;  // most recent first
  std::unordered_map<Key, typename std::list<Entry>::iterator> index_;
};

}  // namespace loci
