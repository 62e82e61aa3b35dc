// A mutex that serves its lockers in the order they asked (a ticket lock): a job that takes it
// in chunks, or a worker that takes it per keyframe, cannot take it back before a thread that
// was already waiting. std::mutex does not queue its waiters: a thread that unlocks and locks
// again at once usually gets it back before a waiter wakes, so a chunked job would starve them.
// Lockable (std::lock_guard works). Waiters sleep on a condition variable; none spins.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <mutex>

namespace loci {

class FifoMutex {
 public:
  void lock() {
    std::unique_lock<std::mutex> guard(mu_);
    const uint64_t ticket = next_++;
    turn_.wait(guard, [&] { return serving_ == ticket; });
  }
  bool try_lock() {
    std::lock_guard<std::mutex> guard(mu_);
    if (next_ != serving_) return false;  // held, or others wait
    ++next_;
    return true;
  }
  void unlock() {
    {
      std::lock_guard<std::mutex> guard(mu_);
      ++serving_;
    }
    turn_.notify_all();  // the next ticket's holder wakes; the others sleep on
  }

  // Threads blocked in lock() now.
  int waiters() const {
    std::lock_guard<std::mutex> guard(mu_);
    const uint64_t queued = next_ - serving_;  // the holder, if any, and those waiting
    return queued == 0 ? 0 : static_cast<int>(queued - 1);
  }

 private:
  mutable std::mutex mu_;
  std::condition_variable turn_;
  uint64_t next_ = 0;     // the ticket the next lock() takes
  uint64_t serving_ = 0;  // the ticket that holds (or may take) the mutex
};

}  // namespace loci
