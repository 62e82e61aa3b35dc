// A read-only query server's copy of a site's map: the objects, robot poses and up its writer
// publishes (MapStore::Publish, server/runtime/map_publisher.h). It loads them at start and again
// whenever the writer publishes (PostgresStore::WaitPublished: LISTEN, so within milliseconds of
// the commit), on its own thread; queries read immutable snapshots and never wait for a reload.
// Each reload's changes (replica_changes.h) go to the watchers of events().
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "common/map_object.h"
#include "common/status.h"
#include "server/map/mapper.h"
#include "server/postgres/postgres_store.h"
#include "server/runtime/event_fanout.h"
#include "server/runtime/readiness.h"

namespace loci::server {

// One publication of the writer, as queries read it.
struct ReplicaSnapshot {
  int64_t version = 0;       // the publication's (0: the writer published nothing yet)
  int64_t published_ns = 0;  // wall time the writer published it
  int64_t loaded_ns = 0;     // wall time this server had it loaded
  std::vector<MapObject> objects;  // in the map, by id
  std::vector<MapObject> removed;  // found gone, with their last state
  std::map<std::string, RobotPose> poses;
  std::optional<Vec3d> up_map;
  std::string levelled_by;
  int64_t last_keyframe_id = 0;
};

// The map objects of a publication's rows: each one's wire form, or its columns when a row has
// none (rows an older writer wrote); InvalidArgument for a wire form that does not parse.
StatusOr<ReplicaSnapshot> SnapshotOf(PublishedMap published);

class ReplicaMap {
 public:
  // Starts following `store`'s site; ready once the first read of it succeeded. At most
  // `max_watchers` subscribers of events() (server.max_watchers).
  explicit ReplicaMap(std::shared_ptr<PostgresStore> store, int max_watchers = 64);
  ~ReplicaMap();
  ReplicaMap(const ReplicaMap&) = delete;
  ReplicaMap& operator=(const ReplicaMap&) = delete;

  // The latest loaded publication (never null once ready; an empty map before).
  std::shared_ptr<const ReplicaSnapshot> Snapshot() const;
  const Readiness& readiness() const { return readiness_; }
  Readiness& readiness() { return readiness_; }
  uint64_t reloads() const { return reloads_; }
  // The object changes of every publication loaded after the first (closed at destruction).
  EventFanout& events() { return events_; }
  const std::string& site() const { return store_->site(); }

 private:
  void Run();
  // Reads the published map when its version is past the loaded one; waits up to `wait`.
  Status Follow(std::chrono::milliseconds wait);

  const std::shared_ptr<PostgresStore> store_;
  Readiness readiness_;
  mutable std::mutex mu_;
  std::shared_ptr<const ReplicaSnapshot> snapshot_;  // guarded by mu_
  EventFanout events_;
  std::atomic<uint64_t> reloads_{0};
  std::atomic<bool> stop_{false};
  std::mutex stop_mu_;
  std::condition_variable stop_cv_;  // wakes the retry wait after an error
  std::thread thread_;
};

}  // namespace loci::server
