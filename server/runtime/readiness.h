// Whether the server's map is loaded. The loading thread reports its progress and its end;
// every call that needs the map asks first (Check), and waiters block until the end.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <vector>

#include "common/status.h"

namespace loci::server {

class Readiness {
 public:
  bool ready() const { return ready_; }
  // OK once loaded; else UNAVAILABLE saying why not (loading, with progress, or the load error).
  Status Check() const;
  // Blocks until the load ended; its status.
  Status Wait();
  // `fn` runs once the map is loaded (at once when it already is), on the loading thread.
  void OnReady(std::function<void()> fn);

  // The loading thread: keyframes replayed of those to replay.
  void Progress(uint64_t done, uint64_t total);
  // The loading thread, once: the load's status; the OnReady functions run when it is OK.
  void Finish(const Status& status);

 private:
  std::atomic<bool> ready_{false};
  std::atomic<uint64_t> done_{0}, total_{0};
  mutable std::mutex mu_;
  std::condition_variable finished_cv_;
  bool finished_ = false;                         // guarded by mu_
  Status status_;                                 // guarded by mu_
  std::vector<std::function<void()>> on_ready_;  // guarded by mu_
};

}  // namespace loci::server
