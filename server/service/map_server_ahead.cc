// MapServer: an unaligned robot's newest keyframe is recognised ahead of a backlog
// (AlignOptions::query_ahead_backlog). Ingest keeps a copy of each unaligned session's newest
// keyframe while keyframes wait; the aligning thread matches it against the shared map between
// the keyframes it recognises in order (RobotAligner::QueryAhead), so a robot that streamed a
// backlog elsewhere is placed within about three keyframes of entering the shared map, not
// after the backlog has been worked through.
#include <spdlog/spdlog.h>

#include "server/service/map_server.h"

namespace loci::server {
namespace {

// Keyframes recognised in order between two queried ahead: an ahead query costs about one
// keyframe's place recognition, so a backlog is worked through at most a quarter slower.
constexpr int kRecognisedPerAhead = 4;

}  // namespace

void MapServer::OfferAhead(const MapperKeyframe& kf) {
  const int backlog = options_.align.query_ahead_backlog;
  if (!aligner_ || backlog <= 0) return;
  if (queue_.size() + align_queue_.size() < static_cast<size_t>(backlog)) return;
  if (!aligner_->Known(kf.session_row) || aligner_->Alignment(kf.session_row)) return;
  // The images are shared, not copied (this runs under the ingest lock): every consumer of a
  // queued keyframe's images only reads them.
  MapperKeyframe copy = kf;
  copy.detections.clear();
  std::lock_guard<std::mutex> lock(ahead_mu_);
  ahead_[kf.session_row] = std::move(copy);
}

std::optional<MapperKeyframe> MapServer::TakeAhead() {
  const bool due = recognised_since_ahead_ >= kRecognisedPerAhead || align_queue_.size() == 0;
  std::lock_guard<std::mutex> lock(ahead_mu_);
  // The session offered longest ago first (each unaligned robot gets its turn), one that sees
  // the shared map before it.
  auto oldest = ahead_.end();
  for (auto it = ahead_.begin(); it != ahead_.end(); ++it) {
    const bool matched = ahead_matched_.count(it->first) > 0;
    if (!due && !matched) continue;
    const bool oldest_matched = oldest != ahead_.end() && ahead_matched_.count(oldest->first);
    if (oldest == ahead_.end() || (matched && !oldest_matched) ||
        (matched == oldest_matched && it->second.keyframe_id < oldest->second.keyframe_id)) {
      oldest = it;
    }
  }
  if (oldest == ahead_.end()) return std::nullopt;
  MapperKeyframe kf = std::move(oldest->second);
  ahead_.erase(oldest);
  recognised_since_ahead_ = 0;
  return kf;
}

void MapServer::QueryAhead(const MapperKeyframe& kf) {
  const AlignOutcome outcome =
      Guarded(kf, "place recognition ahead of the backlog", [&](const AlignKeyframe& in) {
        return aligner_->QueryAhead(in, kf.bgr, kf.depth_m, kf.camera);
      });
  {
    std::lock_guard<std::mutex> lock(ahead_mu_);
    if (outcome.matches.empty() || outcome.alignment) {
      ahead_matched_.erase(kf.session_row);
    } else {
      ahead_matched_.insert(kf.session_row);
    }
  }
  if (outcome.alignment) {
    spdlog::info("session row {} aligned at keyframe {}, recognised ahead of {} waiting keyframes",
                 kf.session_row, kf.keyframe_id, queue_.size() + align_queue_.size());
  }
  if (outcome.alignment || !outcome.matches.empty()) ApplyOutcome(kf, outcome);
}

}  // namespace loci::server
