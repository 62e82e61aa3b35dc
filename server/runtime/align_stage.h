// The alignment stage: robots that start anywhere (server/align/). Its thread takes every keyframe
// the mapping worker mapped or held back in an island, from a bounded queue, and runs place
// recognition on it (RobotAligner) off the mapping worker. What that gives is applied under the
// mapping lock: the verified matches go to the pose graph (graph_stage.h); an aligned session's
// placement is stored and its held keyframes enter the shared map at their new poses, in id order,
// from their stored products, in chunks between two keyframes of the worker (chunked_move.h); a
// join of two islands maps the joining sessions into the other island; a refined placement moves
// the session's mapped keyframes. Then the pose graph solves when due.
//
// An unaligned robot's newest keyframe can be recognised ahead of a backlog (ahead_queries.h).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "common/bounded_queue.h"
#include "server/runtime/ahead_queries.h"
#include "server/runtime/chunked_move.h"
#include "server/runtime/graph_stage.h"
#include "server/runtime/map_context.h"
#include "server/runtime/map_worker.h"
#include "server/runtime/pipeline_progress.h"
#include "server/runtime/replay.h"

namespace loci::server {

// How the latest aligned session's held keyframes entered the map.
struct HeldMergeStats {
  double last_ms = 0;               // wall time, first chunk to the checkpoint after the last
  uint64_t last_chunks = 0;
  uint64_t last_keyframes = 0;      // held keyframes it mapped
  double last_longest_hold_ms = 0;  // the longest single hold of the mapping lock
  double longest_hold_ms = 0;       // ... since start
  uint64_t merged_keyframes = 0;    // held keyframes mapped since start
};

class AlignStage {
 public:
  AlignStage(const MapContext& ctx, MapWorker* worker, GraphStage* graph,
             PipelineProgress* progress);
  ~AlignStage() { Stop(); }
  AlignStage(const AlignStage&) = delete;
  AlignStage& operator=(const AlignStage&) = delete;

  // The mapping worker's keyframes for place recognition.
  BoundedQueue<MapperKeyframe>& input() { return queue_; }
  size_t waiting() const { return queue_.size(); }
  void Start();
  // Recognises what is queued, then ends the thread (after the worker has stopped).
  void Stop();
  // Ingest: keeps a copy of an unaligned session's keyframe as its newest, to be queried ahead
  // of the backlog (AlignOptions::query_ahead_backlog) when at least that many keyframes wait.
  void OfferAhead(const MapperKeyframe& kf);
  // After the map is loaded: maps the stored keyframes of every unaligned session into its
  // island (loading thread, before the worker starts).
  void LoadIslands();
  HeldMergeStats held_merge_stats() const;

 private:
  // Aligned sessions' keyframes held back from the map: those up to upto_keyframe_id (the worker
  // has seen them) that the map lacks.
  struct HeldKeyframes {
    SessionRecord session;
    int64_t upto_keyframe_id = 0;
  };
  // An island join whose sessions' keyframes up to upto_keyframe_id are to be mapped into the
  // island they joined.
  struct JoinedIsland {
    IslandJoin join;
    int64_t upto_keyframe_id = 0;
  };
  void Loop();
  // One place-recognition call for kf (`recognise`, given kf as the aligner takes it); an error
  // or an exception (OpenCV asserts by throwing) is logged with `what` and gives an empty
  // outcome: a keyframe's place recognition must not end the server.
  static AlignOutcome Guarded(
      const MapperKeyframe& kf, const char* what,
      const std::function<StatusOr<AlignOutcome>(const AlignKeyframe&)>& recognise);
  void RecognisePlace(const MapperKeyframe& kf);
  void QueryAhead(const MapperKeyframe& kf);
  // Applies what place recognition gave for kf (its matches, alignments, a join) under the
  // mapping lock, then maps the held keyframes and moves what it placed.
  void ApplyOutcome(const MapperKeyframe& kf, const AlignOutcome& outcome);
  // Mapping lock held: stores the session's placement (the worker maps its next keyframes at it)
  // and drops its island; its held keyframes are for MapHeldKeyframes. An alignment that only
  // refines the placement has none: its mapped keyframes' moves go to `moves`.
  std::optional<HeldKeyframes> ApplyAlignment(const SessionAlignment& alignment,
                                              std::vector<Mapper::KeyframePoseUpdate>* moves);
  // Mapping lock held: stores where the joining island's sessions now sit and drops that island.
  JoinedIsland ApplyJoin(const IslandJoin& join);
  // Maps the held keyframes into the shared map in chunks of align.held_chunk_keyframes, then
  // checkpoints.
  void MapHeldKeyframes(const std::vector<HeldKeyframes>& sessions);
  void MapJoinedIsland(const JoinedIsland& joined);
  // Maps a session's stored keyframes up to upto_keyframe_id that the island lacks into it, at
  // T_island_odom, in chunks; how many.
  uint64_t MapIntoIsland(int64_t session_row, int64_t island_row, const SE3d& T_island_odom,
                         int64_t upto_keyframe_id);
  // The session's stored keyframes up to upto_keyframe_id that `mapped` says are not mapped.
  std::vector<int64_t> UnmappedKeyframeIds(const SessionRecord& session, int64_t upto_keyframe_id,
                                           const std::function<bool(int64_t)>& mapped);
  // The session's stored keyframes with ids in [first_id, last_id], read back (products, or built
  // from images) without the mapping lock; skipped ones are counted in `report`.
  StatusOr<std::vector<LoadedKeyframe>> LoadStored(const SessionRecord& session, int64_t first_id,
                                                   int64_t last_id, LoadReport* report);
  // Mapping lock held: a session's mapped keyframes at its refined placement.
  std::vector<Mapper::KeyframePoseUpdate> SessionMoves(const SessionAlignment& alignment);
  // Applies such moves in chunks of align.loops.apply_chunk_keyframes.
  void MoveSessions(std::vector<Mapper::KeyframePoseUpdate> moves);

  MapContext ctx_;
  MapWorker* worker_;
  GraphStage* graph_;
  PipelineProgress* progress_;
  AheadQueries ahead_;
  BoundedQueue<MapperKeyframe> queue_;
  std::thread thread_;
  mutable std::mutex stats_mu_;
  HeldMergeStats stats_;  // guarded by stats_mu_
};

}  // namespace loci::server
