// Object events to the watchers (WatchObjects, the HTTP event stream): each event is copied into
// every subscribed queue; a full queue (a slow watcher) loses the event, it never blocks the map.
#pragma once

#include <memory>
#include <mutex>
#include <vector>

#include "common/bounded_queue.h"
#include "common/status.h"
#include "server/map/mapper.h"

namespace loci::server {

using ObjectEventQueue = BoundedQueue<ObjectEventOut>;

class EventFanout {
 public:
  explicit EventFanout(int max_watchers) : max_watchers_(max_watchers) {}

  // RESOURCE_EXHAUSTED beyond max_watchers subscribers.
  Status Subscribe(std::shared_ptr<ObjectEventQueue> queue);
  void Unsubscribe(const std::shared_ptr<ObjectEventQueue>& queue);
  void Publish(const std::vector<ObjectEventOut>& events);
  // Closes every queue (shutdown): their readers drain them and end.
  void CloseAll();

 private:
  const int max_watchers_;
  std::mutex mu_;
  std::vector<std::shared_ptr<ObjectEventQueue>> watchers_;  // guarded by mu_
};

}  // namespace loci::server
