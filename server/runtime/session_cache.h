// The robot sessions the server has seen, read through from the store: by public id (each
// keyframe names its session) and by row (the aligner and the pose graph name rows), with each
// session's newest stored stamp for the order check of its next keyframe. Thread-safe.
#pragma once

#include <map>
#include <mutex>
#include <optional>
#include <string>

#include "common/status.h"
#include "server/storage/map_store.h"

namespace loci::server {

class SessionCache {
 public:
  explicit SessionCache(MapStore* store) : store_(store) {}

  // NOT_FOUND for an unknown id; PERMISSION_DENIED when only_robot is given and the session is
  // another robot's.
  StatusOr<SessionRecord> Find(const std::string& session_id,
                               const std::string* only_robot = nullptr);
  std::optional<SessionRecord> ByRow(int64_t session_row);
  // Records (or replaces) a session as it is now stored.
  void Put(const SessionRecord& session);
  void MarkClosed(const std::string& session_id);

  // INVALID_ARGUMENT when the keyframe's stamp is more than backwards_ms before that of an
  // earlier seq of its session.
  Status CheckStampOrder(const KeyframeRecord& record, double backwards_ms);
  // The keyframe was stored: the next one's stamp is checked against it.
  void NoteStored(const KeyframeRecord& record);

 private:
  MapStore* store_;
  std::mutex mu_;
  std::map<std::string, SessionRecord> by_id_;  // guarded by mu_
  std::map<int64_t, LastStamp> last_stamp_;     // by session row, filled on first use; mu_
};

}  // namespace loci::server
