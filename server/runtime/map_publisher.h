// The publisher stage: applies the shared map's changes to the object table (MapStore::Publish)
// at most every publish_interval_s while the map changes, and at Flush, so read-only query
// servers and SQL tools read the map seconds behind its writer rather than a checkpoint behind.
// It owns its thread; it reads the mapper through its thread-safe snapshots.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "common/status.h"
#include "server/map/mapper.h"
#include "server/runtime/readiness.h"
#include "server/storage/map_store.h"

namespace loci::server {

// An object as its object-table row, with its wire form (loci.v1.Object).
ObjectRecord ObjectRow(const MapObject& o);

// The shared map as a whole publication (replace_all): its objects (islands are in other
// frames) as object-table rows with their wire form, every robot's latest pose, the up and how
// the frame was levelled.
MapPublication WholePublication(const Mapper& mapper);

class MapPublisher {
 public:
  // Publishes from `mapper` into `store` once `readiness` reports the map loaded (the load may
  // replace the mapper until then); the first publication replaces the whole table (it may hold
  // an earlier writer's rows).
  MapPublisher(const std::unique_ptr<Mapper>& mapper, MapStore* store, const Readiness& readiness,
               double interval_s);
  ~MapPublisher();  // stops the thread (no last publication: Flush first)
  MapPublisher(const MapPublisher&) = delete;
  MapPublisher& operator=(const MapPublisher&) = delete;

  // Publishes what changed since the last publication, now (nothing when nothing did).
  Status Flush();
  uint64_t publications() const;

 private:
  void Run();
  Status PublishChanges();  // publish_mu_ held

  const std::unique_ptr<Mapper>& mapper_;
  MapStore* const store_;
  const Readiness& readiness_;
  const double interval_s_;
  std::mutex publish_mu_;  // one publication at a time; guards the fields below
  std::map<int64_t, std::string> published_;  // object id -> its wire form, as published
  std::string published_state_;               // poses, up and levelling, as published
  bool published_once_ = false;
  std::atomic<uint64_t> publications_{0};
  std::mutex stop_mu_;
  std::condition_variable stop_cv_;
  bool stop_ = false;  // guarded by stop_mu_
  std::thread thread_;
};

}  // namespace loci::server
