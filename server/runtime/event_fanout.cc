#include "server/runtime/event_fanout.h"

namespace loci::server {

Status EventFanout::Subscribe(std::shared_ptr<ObjectEventQueue> queue) {
  std::lock_guard<std::mutex> lock(mu_);
  if (watchers_.size() >= static_cast<size_t>(max_watchers_)) {
    return absl::ResourceExhaustedError(
        absl::StrCat("already ", watchers_.size(),
                     " WatchObjects streams (server.max_watchers); each holds a server thread"));
  }
  watchers_.push_back(std::move(queue));
  return absl::OkStatus();
}

void EventFanout::Unsubscribe(const std::shared_ptr<ObjectEventQueue>& queue) {
  std::lock_guard<std::mutex> lock(mu_);
  std::erase(watchers_, queue);
}

void EventFanout::Publish(const std::vector<ObjectEventOut>& events) {
  std::lock_guard<std::mutex> lock(mu_);
  for (auto& w : watchers_) {
    for (const auto& e : events) w->TryPush(e);
  }
}

void EventFanout::CloseAll() {
  std::lock_guard<std::mutex> lock(mu_);
  for (auto& w : watchers_) w->Close();
}

}  // namespace loci::server
