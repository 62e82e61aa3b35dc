// How far the keyframes accepted since the start have gone through the stages: queued for the
// mapping worker, mapped (or held in an island), queued for place recognition, recognised.
// Flush waits until every stage has worked through what it was given.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <mutex>

namespace loci::server {

class PipelineProgress {
 public:
  void Queued() { Add(&queued_, 1); }
  void Unqueued() { Add(&queued_, -1); }  // dropped at shutdown (stored: mapped on restart)
  void Mapped() { Add(&mapped_, 1); }
  void ToRecognise() { Add(&to_recognise_, 1); }
  void NotRecognised() { Add(&to_recognise_, -1); }  // dropped at shutdown
  void Recognised() { Add(&recognised_, 1); }

  // Keyframes handed to place recognition and not through it yet.
  uint64_t recognition_pending() const {
    std::lock_guard<std::mutex> lock(mu_);
    return to_recognise_ - recognised_;
  }
  // Blocks until every keyframe queued so far was mapped and, if sent on, recognised.
  void WaitDrained() {
    std::unique_lock<std::mutex> lock(mu_);
    changed_.wait(lock, [&] { return mapped_ >= queued_ && recognised_ >= to_recognise_; });
  }

 private:
  void Add(uint64_t* counter, int delta) {
    {
      std::lock_guard<std::mutex> lock(mu_);
      *counter += static_cast<uint64_t>(delta);
    }
    changed_.notify_all();
  }

  mutable std::mutex mu_;
  std::condition_variable changed_;
  uint64_t queued_ = 0, mapped_ = 0, to_recognise_ = 0, recognised_ = 0;  // guarded by mu_
};

}  // namespace loci::server
