// The ingest gate: a robot's sessions and keyframes enter the server here. A keyframe is
// validated (images decoded under a bounded number of decode slots, limits, stamp order), stored
// in one transaction and acknowledged; a new one is handed on, decoded, to be mapped.
#pragma once

#include <mutex>
#include <optional>
#include <semaphore>
#include <string>

#include "common/status.h"
#include "loci/v1/mapping.pb.h"
#include "server/map/mapper.h"
#include "server/runtime/ingest_times.h"
#include "server/runtime/server_options.h"
#include "server/runtime/session_cache.h"
#include "server/storage/map_store.h"

namespace loci::server {

class IngestGate {
 public:
  IngestGate(const ServerOptions& options, MapStore* store, SessionCache* sessions,
             IngestTimes* times)
      : options_(options),
        store_(store),
        sessions_(sessions),
        times_(times),
        decode_slots_(options.decode_slots) {}

  StatusOr<loci::v1::OpenSessionResponse> OpenSession(const loci::v1::OpenSessionRequest& req);
  StatusOr<loci::v1::CloseSessionResponse> CloseSession(const loci::v1::CloseSessionRequest& req,
                                                        const std::string* only_robot);

  // What became of a keyframe: its ack (problems in its status), and when it was stored for
  // the first time, the decoded keyframe to map. `order` is held from storing it on: the caller
  // queues it for the mapping worker before releasing it, so keyframes are mapped in id order
  // (the order a restart loads them in).
  struct Admitted {
    loci::v1::KeyframeAck ack;
    std::optional<MapperKeyframe> keyframe;
    std::unique_lock<std::mutex> order;
  };
  // `only_robot` (optional): the caller may write only this robot's sessions (PERMISSION_DENIED).
  Admitted Admit(const loci::v1::Keyframe& keyframe, const std::string* only_robot);

 private:
  StatusOr<KeyframeRecord> Validate(const loci::v1::Keyframe& kf, const SessionRecord& session,
                                    MapperKeyframe* decoded);
  // Stores a validated keyframe (the order lock taken) and acknowledges it.
  Admitted Store(const loci::v1::Keyframe& kf, const KeyframeRecord& record, double validate_ms,
                 MapperKeyframe decoded);

  const ServerOptions& options_;
  MapStore* store_;
  SessionCache* sessions_;
  IngestTimes* times_;
  std::counting_semaphore<256> decode_slots_;  // bounds the memory of concurrent image decodes
  std::mutex order_mu_;                        // from storing a keyframe until it is queued
};

// An ack of keyframe `seq` with `status`.
loci::v1::KeyframeAck MakeAck(int64_t seq, const Status& status);

}  // namespace loci::server
