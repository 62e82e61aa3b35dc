#include "server/runtime/readiness.h"

#include <string>

namespace loci::server {

Status Readiness::Check() const {
  if (ready_) return absl::OkStatus();
  std::lock_guard<std::mutex> lock(mu_);
  if (finished_) {
    return absl::UnavailableError(
        absl::StrCat("loci-server could not load its map: ", status_.message()));
  }
  // Progress comes once the checkpoint is restored and the keyframes counted (replay.cc).
  const uint64_t total = total_.load();
  const std::string progress =
      total == 0 ? std::string("reading the stored map")
                 : absl::StrCat(done_.load(), " keyframes replayed after the checkpoint, ", total,
                                " stored");
  return absl::UnavailableError(absl::StrCat("loci-server is loading its map (", progress,
                                             "); retry when the gRPC health service reports "
                                             "SERVING"));
}

Status Readiness::Wait() {
  std::unique_lock<std::mutex> lock(mu_);
  finished_cv_.wait(lock, [&] { return finished_; });
  return status_;
}

void Readiness::OnReady(std::function<void()> fn) {
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (!ready_) {
      on_ready_.push_back(std::move(fn));
      return;
    }
  }
  fn();
}

void Readiness::Progress(uint64_t done, uint64_t total) {
  done_ = done;
  total_ = total;
}

void Readiness::Finish(const Status& status) {
  std::vector<std::function<void()>> callbacks;
  {
    std::lock_guard<std::mutex> lock(mu_);
    finished_ = true;
    status_ = status;
    ready_ = status.ok();
    if (ready_) callbacks = std::move(on_ready_);
  }
  finished_cv_.notify_all();
  for (auto& fn : callbacks) fn();
}

}  // namespace loci::server
