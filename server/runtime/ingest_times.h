// Mean times of the server's stages per keyframe since the start, added from every ingest
// stream and the mapping worker: validation with image decoding (thread CPU time), the storage
// transaction and mapping (wall time), and the mapping worker's longest wait for the map.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstdint>

namespace loci::server {

class IngestTimes {
 public:
  void AddAccepted(double validate_ms, double store_ms) {
    // fetch_add: `x = x + y` on an atomic loses updates when several streams ingest at once.
    validate_ms_total_.fetch_add(validate_ms);
    store_ms_total_.fetch_add(store_ms);
    ++accepted_;
  }
  void AddMapped(double mapping_ms) {
    mapping_ms_total_.fetch_add(mapping_ms);
    ++mapped_;
  }
  // The mapping worker only: a plain load and store keep the maximum.
  void NoteWorkerWait(double wait_ms) {
    worker_longest_wait_ms_ = std::max(worker_longest_wait_ms_.load(), wait_ms);
  }

  double validate_ms_mean() const { return Mean(validate_ms_total_, accepted_); }
  double store_ms_mean() const { return Mean(store_ms_total_, accepted_); }
  // Keyframes mapped by the worker (replay excluded).
  double mapping_ms_mean() const { return Mean(mapping_ms_total_, mapped_); }
  double worker_longest_wait_ms() const { return worker_longest_wait_ms_; }

 private:
  static double Mean(const std::atomic<double>& total, const std::atomic<uint64_t>& n) {
    const uint64_t count = n;
    return count == 0 ? 0.0 : total / static_cast<double>(count);
  }

  std::atomic<double> validate_ms_total_{0}, store_ms_total_{0}, mapping_ms_total_{0};
  std::atomic<uint64_t> accepted_{0}, mapped_{0};
  std::atomic<double> worker_longest_wait_ms_{0};
};

}  // namespace loci::server
