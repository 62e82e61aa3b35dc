#include "server/runtime/session_cache.h"

#include "common/time.h"

namespace loci::server {

StatusOr<SessionRecord> SessionCache::Find(const std::string& session_id,
                                           const std::string* only_robot) {
  std::optional<SessionRecord> found;
  {
    std::lock_guard<std::mutex> lock(mu_);
    auto it = by_id_.find(session_id);
    if (it != by_id_.end()) found = it->second;
  }
  if (!found) {
    LOCI_ASSIGN_OR_RETURN(found, store_->FindSession(session_id));
    if (found) Put(*found);
  }
  if (!found) {
    return absl::NotFoundError(
        absl::StrCat("unknown session '", session_id, "' (call OpenSession first)"));
  }
  if (only_robot != nullptr && found->robot_name != *only_robot) {
    return absl::PermissionDeniedError(absl::StrCat(
        "session '", session_id, "' belongs to another robot than '", *only_robot, "'"));
  }
  return *found;
}

std::optional<SessionRecord> SessionCache::ByRow(int64_t session_row) {
  {
    std::lock_guard<std::mutex> lock(mu_);
    for (const auto& [id, s] : by_id_) {
      if (s.row_id == session_row) return s;
    }
  }
  // Not cached (a session read back after a restart): from the store.
  auto all = store_->ListSessions();
  if (!all.ok()) return std::nullopt;
  for (const SessionRecord& r : *all) {
    if (r.row_id != session_row) continue;
    Put(r);
    return r;
  }
  return std::nullopt;
}

void SessionCache::Put(const SessionRecord& session) {
  std::lock_guard<std::mutex> lock(mu_);
  by_id_[session.session_id] = session;
}

void SessionCache::MarkClosed(const std::string& session_id) {
  std::lock_guard<std::mutex> lock(mu_);
  by_id_[session_id].open = false;
}

Status SessionCache::CheckStampOrder(const KeyframeRecord& rec, double backwards_ms) {
  std::unique_lock<std::mutex> lock(mu_);
  auto it = last_stamp_.find(rec.session_row);
  if (it == last_stamp_.end()) {
    lock.unlock();
    LOCI_ASSIGN_OR_RETURN(LastStamp stored, store_->LastStoredStamp(rec.session_row));
    lock.lock();
    it = last_stamp_.emplace(rec.session_row, stored).first;
  }
  const LastStamp last = it->second;
  const int64_t tolerance_ns = SecondsToNs(1e-3 * backwards_ms);
  if (rec.seq > last.seq && rec.t_ns < last.t_ns - tolerance_ns) {
    return absl::InvalidArgumentError(absl::StrCat(
        "t_ns ", rec.t_ns, " of seq ", rec.seq, " is ", (last.t_ns - rec.t_ns) / 1'000'000,
        " ms before seq ", last.seq, "'s (stamps must not go back more than ", backwards_ms,
        " ms)"));
  }
  return absl::OkStatus();
}

void SessionCache::NoteStored(const KeyframeRecord& rec) {
  std::lock_guard<std::mutex> lock(mu_);
  LastStamp& last = last_stamp_[rec.session_row];
  if (rec.seq > last.seq) last = {rec.seq, rec.t_ns};
}

}  // namespace loci::server
