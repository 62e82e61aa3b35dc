#include "server/runtime/ahead_queries.h"

namespace loci::server {
namespace {

// Keyframes recognised in order between two queried ahead: an ahead query costs about one
// keyframe's place recognition, so a backlog is worked through at most a quarter slower.
constexpr int kRecognisedPerAhead = 4;

}  // namespace

void AheadQueries::Offer(const MapperKeyframe& kf) {
  // The images are shared, not copied (this runs under the ingest lock): every consumer of a
  // queued keyframe's images only reads them.
  MapperKeyframe copy = kf;
  copy.detections.clear();
  std::lock_guard<std::mutex> lock(mu_);
  offers_[kf.session_row] = std::move(copy);
}

std::optional<MapperKeyframe> AheadQueries::Take(bool none_waiting) {
  const bool due = recognised_since_take_ >= kRecognisedPerAhead || none_waiting;
  std::lock_guard<std::mutex> lock(mu_);
  auto oldest = offers_.end();
  for (auto it = offers_.begin(); it != offers_.end(); ++it) {
    const bool matched = matched_.count(it->first) > 0;
    if (!due && !matched) continue;
    const bool oldest_matched = oldest != offers_.end() && matched_.count(oldest->first);
    if (oldest == offers_.end() || (matched && !oldest_matched) ||
        (matched == oldest_matched && it->second.keyframe_id < oldest->second.keyframe_id)) {
      oldest = it;
    }
  }
  if (oldest == offers_.end()) return std::nullopt;
  MapperKeyframe kf = std::move(oldest->second);
  offers_.erase(oldest);
  recognised_since_take_ = 0;
  return kf;
}

void AheadQueries::NoteOutcome(int64_t session_row, bool matched_unaligned) {
  std::lock_guard<std::mutex> lock(mu_);
  if (matched_unaligned) {
    matched_.insert(session_row);
  } else {
    matched_.erase(session_row);
  }
}

}  // namespace loci::server
