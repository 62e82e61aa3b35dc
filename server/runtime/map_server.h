// The server's runtime, independent of the transport: it composes the stages, each owning its
// state: the ingest gate (sessions, validation, storage, acks: ingest_gate.h), the bounded
// queue to the mapping worker thread (the shared map and the islands), the aligning thread
// (place recognition, alignment decisions, pose-graph solves: map_server_align.cc,
// map_server_loops.cc), the checkpointer (checkpointer.h) and the object-event fan-out
// (event_fanout.h). The gRPC and HTTP services (server/service, server/http) are thin adapters.
#pragma once

#include <atomic>
#include <chrono>
#include <functional>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <thread>
#include <vector>

#include "common/status.h"
#include "server/detect/keyframe_detection.h"
#include "loci/v1/mapping.pb.h"
#include "server/align/loop_closer.h"
#include "server/align/robot_aligner.h"
#include "common/bounded_queue.h"
#include "common/fifo_mutex.h"
#include "server/map/mapper.h"
#include "server/runtime/ahead_queries.h"
#include "server/runtime/checkpointer.h"
#include "server/runtime/map_publisher.h"
#include "server/runtime/chunked_move.h"
#include "server/runtime/event_fanout.h"
#include "server/runtime/ingest_gate.h"
#include "server/runtime/ingest_times.h"
#include "server/runtime/island_maps.h"
#include "server/runtime/pipeline_progress.h"
#include "server/runtime/readiness.h"
#include "server/runtime/replay.h"
#include "server/runtime/server_options.h"
#include "server/runtime/session_cache.h"
#include "server/runtime/store_feature_store.h"
#include "server/runtime/store_image_source.h"
#include "server/storage/map_store.h"

namespace loci::server {

class MapServer {
 public:
  // Opens the store (SQLite at options.db_path unless `store` is given), loads the map
  // (replay.h: checkpoint, then products or raw keyframes after it), then starts the mapping
  // worker. `detection` (server-side detection of keyframes) may be null.
  static StatusOr<std::unique_ptr<MapServer>> Open(
      const ServerOptions& options, std::shared_ptr<MapStore> store = nullptr,
      std::shared_ptr<KeyframeDetection> detection = nullptr);
  // As Open, but returns once the store is open and loads the map on a background thread:
  // until ready(), every call but these accessors answers UNAVAILABLE (CheckReady).
  static StatusOr<std::unique_ptr<MapServer>> OpenAsync(
      const ServerOptions& options, std::shared_ptr<MapStore> store = nullptr,
      std::shared_ptr<KeyframeDetection> detection = nullptr);
  // Drains the queue, stops the worker and writes a last checkpoint.
  ~MapServer();

  // Whether the map is loaded and the server takes calls; OK, or UNAVAILABLE saying why not
  // (loading, with progress, or the load error).
  bool ready() const { return readiness_.ready(); }
  Status CheckReady() const { return readiness_.Check(); }
  // Blocks until the map is loaded or failed to load; the load's status.
  Status WaitReady() { return readiness_.Wait(); }
  // `fn` runs once the map is loaded (at once when it already is), on the loading thread.
  void OnReady(std::function<void()> fn) { readiness_.OnReady(std::move(fn)); }
  const LoadReport& load_report() const { return load_report_; }
  // Moves mapped keyframes to corrected poses (T_base_kf) and re-derives what they touch
  // (Mapper::UpdateKeyframePoses) between two mapped keyframes, reading their products from the
  // store; the object events go to the watchers. The corrected poses live in the next
  // checkpoint. Returns how many keyframes moved.
  StatusOr<size_t> UpdateKeyframePoses(const std::vector<Mapper::KeyframePoseUpdate>& updates);
  // Writes a checkpoint of the map now (on the caller's thread; call between keyframes, e.g.
  // after Flush). The checkpoint covers every keyframe mapped so far.
  Status Checkpoint();
  MapServer(const MapServer&) = delete;
  MapServer& operator=(const MapServer&) = delete;

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
  // Keyframes waiting for the mapping worker or for place recognition.
  size_t queue_depth() const { return queue_.size() + progress_.recognition_pending(); }
  uint64_t replayed_keyframes() const { return replayed_; }
  // Robot alignment (nullptr when align.enabled is false): its statistics.
  std::optional<AlignStats> align_stats() const;
  // How long a session aligned by place recognition (since this start) waited for it.
  std::optional<AlignmentDelay> alignment_delay(int64_t session_row) const {
    return aligner_ ? aligner_->Delay(session_row) : std::nullopt;
  }
  // Loop closure (nullptr when align.loops.enabled or align.enabled is false): its statistics.
  std::optional<LoopStats> loop_stats() const;
  // Whether the stored keyframes are back in place recognition after a start (Reindex).
  bool reindexed() const { return reindexed_; }
  // Keyframes of robots that were held back and entered the map when their robot was aligned.
  uint64_t merged_keyframes() const { return merged_keyframes_; }
  // How the latest aligned session's held keyframes entered the map (map_server_align.cc).
  struct HeldMergeStats {
    double last_ms = 0;               // wall time, first chunk to the checkpoint after the last
    uint64_t last_chunks = 0;
    uint64_t last_keyframes = 0;      // held keyframes it mapped
    double last_longest_hold_ms = 0;  // the longest single hold of the mapping lock
    double longest_hold_ms = 0;       // ... since start
  };
  HeldMergeStats held_merge_stats() const;
  // Checkpoints written since start.
  uint64_t checkpoints_written() const { return checkpointer_.written(); }
  // Mean stage times per keyframe since start (validation, storage, mapping; ingest_times.h).
  const IngestTimes& times() const { return times_; }

 private:
  MapServer(const ServerOptions& options, std::shared_ptr<MapStore> store,
            std::shared_ptr<KeyframeDetection> detection);
  void WorkerLoop();
  // Stores keyframes' corrected poses, in the frame of the map holding them (map_row:
  // kSharedGraph, the shared base frame, or an unaligned session's island's row), and gives them
  // to the aligner.
  Status StoreCorrectedPoses(const std::vector<Mapper::KeyframePoseUpdate>& updates,
                             int64_t map_row);
  // UpdateKeyframePoses with mapping_mu_ held by the caller.
  StatusOr<size_t> UpdateKeyframePosesLocked(const std::vector<Mapper::KeyframePoseUpdate>& updates,
                                             bool rebuild_octomap = true);
  // Maps (or, for an unaligned session, holds back) one queued keyframe (map_server_align.cc);
  // worker thread, mapping_mu_ held.
  struct Queued {
    bool recognise = false;   // the keyframe goes on to place recognition
    bool shared_map = false;  // it was mapped into the shared map (not held back in an island)
  };
  Queued MapQueued(MapperKeyframe& kf);
  // The aligning thread: place recognition of every mapped or held keyframe, off the mapping
  // worker; then, with mapping_mu_, its matches, an alignment it completes, a graph solve.
  void AlignLoop();
  void RecognisePlace(const MapperKeyframe& kf);
  // One place-recognition call for kf (`recognise`, given kf as the aligner takes it); an error
  // or an exception (OpenCV asserts by throwing) is logged with `what` and gives an empty
  // outcome: a keyframe's place recognition must not end the server.
  static AlignOutcome Guarded(const MapperKeyframe& kf, const char* what,
                              const std::function<StatusOr<AlignOutcome>(const AlignKeyframe&)>&
                                  recognise);
  // Applies what place recognition gave for kf (its matches, alignments, a join) under
  // mapping_mu_, then maps the held keyframes and moves what it placed (aligning thread).
  void ApplyOutcome(const MapperKeyframe& kf, const AlignOutcome& outcome);
  // Ingest: keeps a copy of an unaligned session's keyframe as its newest, to be queried ahead
  // of the backlog (AlignOptions::query_ahead_backlog) when at least that many keyframes wait.
  void OfferAhead(const MapperKeyframe& kf);
  void QueryAhead(const MapperKeyframe& kf);
  // Tells the aligner about a session on its first keyframe; the map's first keyframe makes its
  // session the origin.
  void DeclareSession(int64_t session_row);
  // An aligned session's keyframes held back from the map: those up to upto_keyframe_id (the
  // worker has seen them) that the map lacks.
  struct HeldKeyframes {
    SessionRecord session;
    int64_t upto_keyframe_id = 0;
  };
  // mapping_mu_ held: stores the session's placement (the worker maps its next keyframes at
  // it) and drops its island; its held keyframes are for MapHeldKeyframes. An alignment that
  // only refines the placement has none: its mapped keyframes' moves go to `moves`.
  std::optional<HeldKeyframes> ApplyAlignment(const SessionAlignment& alignment,
                                              std::vector<Mapper::KeyframePoseUpdate>* moves);
  // Before an island is dropped (aligned, or joined to another): stores its keyframes' poses, as
  // its own loop closure corrected them, in the frame of the map that takes them
  // (T_to_island * T_island_kf: the shared base frame, or the other island's; to_map_row says
  // which, as kSharedGraph or the island's row), so they enter it corrected rather than at their
  // odometry. False when there is no such island or the poses
  // were not stored.
  bool StoreIslandPoses(int64_t island_row, int64_t to_map_row, const SE3d& T_to_island);
  // Maps the held keyframes into the shared map in chunks of align.held_chunk_keyframes, each
  // under mapping_mu_ (not held by the caller), then checkpoints.
  void MapHeldKeyframes(const std::vector<HeldKeyframes>& sessions);
  // The session's stored keyframes up to upto_keyframe_id that `mapped` says are not mapped
  // (metadata only; without mapping_mu_).
  std::vector<int64_t> UnmappedKeyframeIds(const SessionRecord& session, int64_t upto_keyframe_id,
                                           const std::function<bool(int64_t)>& mapped);
  // The session's stored keyframes with ids in [first_id, last_id], read back (products, or
  // built from images) without mapping_mu_; skipped ones are counted in `report`.
  StatusOr<std::vector<LoadedKeyframe>> LoadStored(const SessionRecord& session, int64_t first_id,
                                                   int64_t last_id, LoadReport* report);
  // An island join whose sessions' keyframes up to upto_keyframe_id (the worker has seen them)
  // are to be mapped into the island they joined.
  struct JoinedIsland {
    IslandJoin join;
    int64_t upto_keyframe_id = 0;
  };
  // mapping_mu_ held: stores where the joining island's sessions now sit and drops that island.
  JoinedIsland ApplyJoin(const IslandJoin& join);
  // Maps the joined sessions' keyframes into the island they joined (mapping_mu_ not held).
  void MapJoinedIsland(const JoinedIsland& joined);
  // Maps a session's stored keyframes up to upto_keyframe_id that the island lacks into it, at
  // T_island_odom, in chunks of align.held_chunk_keyframes, each under mapping_mu_ (not held by
  // the caller); how many.
  uint64_t MapIntoIsland(int64_t session_row, int64_t island_row, const SE3d& T_island_odom,
                         int64_t upto_keyframe_id);
  // An island's name: its first session's id.
  std::string IslandName(int64_t island_row);
  // After a restart: indexes every stored keyframe for place recognition from its stored
  // features, or its images where it has none, on the loading thread once the map is ready
  // (new keyframes are indexed meanwhile).
  void Reindex();
  struct ReindexCounts {
    uint64_t from_features = 0, from_images = 0, without_images = 0;
  };
  // Whether the keyframe came in since this start (the aligning thread has it).
  bool LiveKeyframe(int64_t keyframe_id) const;
  // Whether Reindex still has to index the keyframe.
  bool ToReindex(const KeyframeRecord& rec);
  // false when the keyframe has no usable stored features.
  bool ReindexFromFeatures(const KeyframeRecord& rec, ReindexCounts* counts);
  void ReindexFromImages(const KeyframeRecord& rec, ReindexCounts* counts);
  // A session's mapped keyframes at its refined placement (mapping_mu_ held).
  std::vector<Mapper::KeyframePoseUpdate> SessionMoves(const SessionAlignment& alignment);
  // Applies such moves in chunks of align.loops.apply_chunk_keyframes, each under mapping_mu_
  // (not held by the caller).
  void MoveSessions(std::vector<Mapper::KeyframePoseUpdate> moves);
  // Loop closure (map_server_loops.cc), mapping_mu_ held: records the keyframe (worker) and
  // the verified matches of a keyframe of session query_session_row (aligning thread; stored).
  void RecordForLoops(const MapperKeyframe& kf);
  void RecordMatches(int64_t query_session_row, const std::vector<VerifiedMatch>& matches);
  // The pose graph a session's keyframes are in: kSharedGraph when it is aligned, else its
  // island's row (mapping_mu_ held).
  int64_t GraphOf(int64_t session_row) const;
  // The graph whose next solve a match (candidate a_keyframe_id, found by a keyframe of
  // query_graph) counts towards.
  int64_t MatchGraph(int64_t a_keyframe_id, int64_t query_graph) const;
  // The map a pose-graph solution moves, and how (each call with mapping_mu_ held).
  struct SolveTarget {
    int64_t graph = kSharedGraph;  // LoopCloser's graph key
    // The map (null: gone, an island aligned or joined another); the same pointer while it is
    // the same map.
    std::function<std::shared_ptr<const Mapper>()> map;
    // A session follows its newest keyframe's correction: its odometry frame's new placement
    // in the map's base frame (T_base_odom, or T_island_odom).
    std::function<void(int64_t session_row, const SE3d& T_base_odom)> place;
    // Moves one chunk of keyframes (`last`: the OctoMap is rebuilt after it).
    std::function<StatusOr<size_t>(const std::vector<Mapper::KeyframePoseUpdate>&, bool last)> move;
  };
  SolveTarget SharedTarget();
  SolveTarget IslandTarget(int64_t island_row);
  // Aligning thread, without mapping_mu_: solves the shared map's pose graph when due, then
  // each island's (the lock is taken for the snapshot and to apply the solution, not while
  // solving).
  void MaybeCloseLoops();
  void CloseLoops(const SolveTarget& target);
  // Moves the solved keyframes and those mapped during the solve, in chunks of
  // align.loops.apply_chunk_keyframes, each under mapping_mu_ (not held by the caller). `map`:
  // the target's map the solve started from (a different one now: the solution is dropped).
  void ApplySolution(const SolveTarget& target, const std::shared_ptr<const Mapper>& map,
                     const SE3d& T_map_base, const std::vector<Mapper::KeyframePoseUpdate>& solved,
                     const GraphResult& result);
  // mapping_mu_ held: the solution's moves in `map`'s base frame, plus those of the keyframes
  // mapped during the solve (their number in *late_count).
  std::vector<Mapper::KeyframePoseUpdate> SolutionUpdates(
      const Mapper& map, const std::vector<Mapper::KeyframePoseUpdate>& solved,
      const GraphResult& result, size_t* late_count);
  // After a solve: each moved session's placement follows its newest mapped keyframe, so the
  // keyframes it sends next continue from the corrected pose.
  // `mapped`: the keyframes the solve saw (id order); `moved`: their corrected poses.
  void FollowCorrections(const SolveTarget& target,
                         const std::vector<Mapper::KeyframePoseUpdate>& mapped,
                         const std::vector<Mapper::KeyframePoseUpdate>& moved);
  // Reads a keyframe's stored products (for moves; the store outlives every reader).
  Mapper::ProductSource ProductsFromStore() const;
  // Stored matches into the loop closer (loading thread, while re-indexing); those found by a
  // keyframe in `unsolved` (keyframe id -> its graph) count towards that graph's next solve.
  void LoadPlaceMatches(const std::map<int64_t, int64_t>& unsolved);
  void LoadLoop();
  // After the map is loaded: maps the stored keyframes of every unaligned session into its
  // island (loading thread, before the worker starts).
  void LoadIslands();
  // After the map is loaded: every stored session with keyframes is declared to the aligner,
  // with its placement or island, before a keyframe or a join can need it (loading thread).
  void DeclareStoredSessions();

  ServerOptions options_;
  std::shared_ptr<MapStore> store_;
  std::shared_ptr<KeyframeDetection> detection_;
  std::unique_ptr<Mapper> mapper_;
  std::unique_ptr<StoreFeatureStore> features_;  // aligner_'s, in store_
  std::unique_ptr<StoreImageSource> images_;     // aligner_'s dense refinement's, from store_
  std::unique_ptr<RobotAligner> aligner_;  // used by the worker thread only (Stats: any)
  std::unique_ptr<LoopCloser> closer_;     // with aligner_ and align.loops.enabled
  std::unique_ptr<IslandMaps> islands_;    // with aligner_

  // The stages' own state.
  Readiness readiness_;
  EventFanout events_;
  SessionCache sessions_;
  IngestTimes times_;
  IngestGate gate_;
  Checkpointer checkpointer_;  // its counters guarded by mapping_mu_ once the worker runs
  PipelineProgress progress_;
  AheadQueries ahead_;
  MapPublisher publisher_;  // the object table; reads mapper_ once readiness_ says loaded

  // The loading thread (LoadLoop, then Reindex).
  std::thread loader_;
  std::atomic<bool> stop_loading_{false};
  LoadReport load_report_;
  uint64_t replayed_ = 0;
  std::atomic<bool> reindexed_{false};

  // Held by the worker per keyframe, and by the aligning thread per chunk of a move or merge.
  FifoMutex mapping_mu_;
  BoundedQueue<MapperKeyframe> queue_;  // to the mapping worker
  std::thread worker_;
  std::atomic<int64_t> worker_last_id_{0};  // the last keyframe the worker mapped or held
  std::atomic<int64_t> first_live_id_{0};   // the first keyframe ingested since the start

  BoundedQueue<MapperKeyframe> align_queue_;  // mapped or held keyframes, with their images
  std::thread align_thread_;
  std::mutex close_loops_mu_;  // one CloseLoops at a time (aligning and loading threads)
  std::atomic<uint64_t> merged_keyframes_{0};
  mutable std::mutex held_merge_mu_;
  HeldMergeStats held_merge_stats_;  // guarded by held_merge_mu_
};

}  // namespace loci::server
