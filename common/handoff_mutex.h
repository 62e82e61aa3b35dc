// A mutex that a long job taking it in chunks can hand to the threads waiting for it between two
// chunks. std::mutex does not queue its waiters: a thread that unlocks and locks again at once
// usually gets it back before a waiter wakes, so a chunked job would still starve them (the
// mapping worker waited 6 chunks of 60 ms for one keyframe in `loci bench restart --move`).
// Lockable (std::lock_guard works).
#pragma once

#include <atomic>
#include <cstdint>
#include <mutex>
#include <thread>

namespace loci {

class HandoffMutex {
 public:
  void lock() {
    waiting_.fetch_add(1);
    mu_.lock();
    waiting_.fetch_sub(1);
    acquired_.fetch_add(1);
  }
  bool try_lock() {
    if (!mu_.try_lock()) return false;
    acquired_.fetch_add(1);
    return true;
  }
  void unlock() { mu_.unlock(); }

  // Call without holding it: when threads wait for the mutex, returns once one of them has had
  // it (it may still hold it). Returns at once when none waits.
  void LetWaitersIn() {
    if (waiting_.load() == 0) return;
    const uint64_t seen = acquired_.load();
    while (acquired_.load() == seen && waiting_.load() > 0) std::this_thread::yield();
  }

  // Threads blocked in lock() now.
  int waiters() const { return waiting_.load(); }

 private:
  std::mutex mu_;
  std::atomic<int> waiting_{0};
  std::atomic<uint64_t> acquired_{0};
};

}  // namespace loci
