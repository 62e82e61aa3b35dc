// The server's runtime, independent of the transport. It owns what the stages share (the store,
// the maps, the sessions, the checkpointer, the object-event fan-out: map_context.h) and composes
// the stages, each with its own state and thread: the ingest gate (sessions, validation, storage,
// acks: ingest_gate.h) -> a bounded queue -> the mapping worker (the shared map and the islands,
// map_worker.h) -> a bounded queue -> the alignment stage (place recognition and alignment
// decisions, align_stage.h), which hands verified matches to the pose-graph stage (solves and
// their corrections, graph_stage.h); the checkpointer (checkpointer.h), the publisher of the
// object table (map_publisher.h) and, after a restart, the re-index (reindexer.h). The gRPC and
// HTTP services (server/service, server/http) are thin adapters over this class.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <thread>
#include <vector>

#include "common/status.h"
#include "loci/v1/mapping.pb.h"
#include "server/align/loop_closer.h"
#include "server/align/robot_aligner.h"
#include "server/detect/keyframe_detection.h"
#include "server/map/mapper.h"
#include "server/runtime/align_stage.h"
#include "server/runtime/checkpointer.h"
#include "server/runtime/event_fanout.h"
#include "server/runtime/graph_stage.h"
#include "server/runtime/ingest_gate.h"
#include "server/runtime/ingest_times.h"
#include "server/runtime/island_maps.h"
#include "server/runtime/map_context.h"
#include "server/runtime/map_publisher.h"
#include "server/runtime/map_worker.h"
#include "server/runtime/pipeline_progress.h"
#include "server/runtime/readiness.h"
#include "server/runtime/reindexer.h"
#include "server/runtime/replay.h"
#include "server/runtime/server_options.h"
#include "server/runtime/session_cache.h"
#include "server/runtime/store_feature_store.h"
#include "server/runtime/store_image_source.h"
#include "server/storage/map_store.h"

namespace loci::server {

// The runtime's counters since start.
struct RuntimeStats {
  size_t queue_depth = 0;  // keyframes waiting for the mapping worker or for place recognition
  uint64_t replayed_keyframes = 0;  // mapped again by the load
  bool reindexed = false;  // the stored keyframes are back in place recognition (reindexer.h)
  uint64_t checkpoints_written = 0;
  HeldMergeStats held_merge;        // aligned robots' held keyframes entering the map
  std::optional<AlignStats> align;  // robot alignment (none when align.enabled is false)
  std::optional<LoopStats> loops;   // loop closure (none when it is off)
};

class MapServer {
 public:
  // Opens the store (SQLite at options.db_path unless `store` is given), loads the map
  // (replay.h: checkpoint, then products or raw keyframes after it), then starts the mapping
  // worker. `detection` (server-side detection of keyframes) may be null.
  static StatusOr<std::unique_ptr<MapServer>> Open(
      const ServerOptions& options, std::shared_ptr<MapStore> store = nullptr,
      std::shared_ptr<KeyframeDetection> detection = nullptr);
  // As Open, but returns once the store is open and loads the map on a background thread:
  // until the readiness says loaded, every call but these accessors answers UNAVAILABLE
  // (CheckReady).
  static StatusOr<std::unique_ptr<MapServer>> OpenAsync(
      const ServerOptions& options, std::shared_ptr<MapStore> store = nullptr,
      std::shared_ptr<KeyframeDetection> detection = nullptr);
  // Drains the queues, stops the stages and writes a last checkpoint.
  ~MapServer();
  MapServer(const MapServer&) = delete;
  MapServer& operator=(const MapServer&) = delete;

  // Whether the map is loaded (ready, Wait, OnReady: run once loaded, on the loading thread).
  Readiness& readiness() { return readiness_; }
  // OK, or UNAVAILABLE saying why not (loading, with progress, or the load error).
  Status CheckReady() const { return readiness_.Check(); }
  const LoadReport& load_report() const { return load_report_; }
  // Moves mapped keyframes to corrected poses (T_base_kf) and re-derives what they touch
  // (Mapper::UpdateKeyframePoses) between two mapped keyframes, reading their products from the
  // store; the object events go to the watchers. The corrected poses live in the next
  // checkpoint. Returns how many keyframes moved.
  StatusOr<size_t> UpdateKeyframePoses(const std::vector<Mapper::KeyframePoseUpdate>& updates);
  // Writes a checkpoint of the map now (on the caller's thread; call between keyframes, e.g.
  // after Flush). The checkpoint covers every keyframe mapped so far.
  Status Checkpoint() { return checkpointer_.Write(); }

  StatusOr<loci::v1::OpenSessionResponse> OpenSession(const loci::v1::OpenSessionRequest& req);
  // Never fails the call: problems are reported in the ack's status. `only_robot` (optional):
  // the caller may write only this robot's sessions (auth.h); others get PERMISSION_DENIED.
  loci::v1::KeyframeAck Ingest(const loci::v1::Keyframe& keyframe,
                               const std::string* only_robot = nullptr);
  StatusOr<loci::v1::CloseSessionResponse> CloseSession(const loci::v1::CloseSessionRequest& req,
                                                        const std::string* only_robot = nullptr);
  // Blocks until every keyframe queued so far has been mapped, then publishes the object table.
  void Flush();

  // Object events go to every queue subscribed here (at most options().max_watchers).
  EventFanout& events() { return events_; }
  const Mapper& mapper() const { return *mapper_; }
  // The object maps of the sessions not aligned yet (nullptr when align.enabled is false).
  const IslandMaps* islands() const { return islands_.get(); }
  MapStore& store() { return *store_; }
  const ServerOptions& options() const { return options_; }
  RuntimeStats stats() const;
  // How long a session aligned by place recognition (since this start) waited for it.
  std::optional<AlignmentDelay> alignment_delay(int64_t session_row) const {
    return aligner_ ? aligner_->Delay(session_row) : std::nullopt;
  }
  // Mean stage times per keyframe since start (validation, storage, mapping; ingest_times.h).
  const IngestTimes& times() const { return times_; }

 private:
  MapServer(const ServerOptions& options, std::shared_ptr<MapStore> store,
            std::shared_ptr<KeyframeDetection> detection);
  // The loading thread: the map, the islands and the sessions, then the stages' threads, then
  // the re-index.
  void LoadLoop();

  // What the stages share (map_context.h).
  ServerOptions options_;
  std::shared_ptr<MapStore> store_;
  std::shared_ptr<KeyframeDetection> detection_;
  std::unique_ptr<Mapper> mapper_;
  std::unique_ptr<StoreFeatureStore> features_;  // aligner_'s, in store_
  std::unique_ptr<StoreImageSource> images_;     // aligner_'s dense refinement's, from store_
  std::unique_ptr<RobotAligner> aligner_;  // used by the alignment stage (Stats: any thread)
  std::unique_ptr<LoopCloser> closer_;     // with aligner_ and align.loops.enabled
  std::unique_ptr<IslandMaps> islands_;    // with aligner_
  Readiness readiness_;
  EventFanout events_;
  SessionCache sessions_;
  IngestTimes times_;
  Checkpointer checkpointer_;  // its counters guarded by the mapping lock once the worker runs
  PipelineProgress progress_;
  std::atomic<bool> stop_loading_{false};
  MapContext ctx_;

  // The stages.
  IngestGate gate_;
  MapWorker worker_;
  GraphStage graph_;
  AlignStage align_;
  Reindexer reindexer_;
  MapPublisher publisher_;  // the object table; reads mapper_ once readiness_ says loaded

  // The loading thread (LoadLoop, then the re-index).
  std::thread loader_;
  LoadReport load_report_;
  uint64_t replayed_ = 0;
};

}  // namespace loci::server
