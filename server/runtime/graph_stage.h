// The pose-graph stage: loop closure and robot merges through the keyframe pose graph
// (server/align/loop_closer.h). The mapping worker records every keyframe's odometry in the loop
// closer, place recognition every verified match (RecordMatches, stored in `place_matches`);
// when enough new matches are in, MaybeCloseLoops (on the aligning thread) solves the graph over
// a snapshot of the mapped keyframes in the map frame (z up: 4-DoF when gravity fixed it)
// without the mapping lock. Then each moved session's placement follows its newest keyframe, so
// the robot's own pose stream needs no change, and the moved keyframes are re-derived
// (Mapper::UpdateKeyframePoses, which emits the object events) in chunks, each under the mapping
// lock (chunked_move.h); those mapped during the solve follow their session (late_keyframes.h).
//
// Each map island (an unaligned robot's own map, island_maps.h) has a graph of its own over its
// keyframes in its frame (keyed by the island's row), solved and applied the same way through
// MapInstance (map_instance.h): its sessions' T_island_odom follow their corrected newest
// keyframes, and its map is re-derived. The island's corrected poses are stored (in its frame),
// and a restart maps the island again at them; keyframes newer than its last solve at
// T_island_odom x odometry.
#pragma once

#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <vector>

#include "server/runtime/map_context.h"
#include "server/runtime/map_instance.h"
#include "server/runtime/map_worker.h"

namespace loci::server {

class GraphStage {
 public:
  GraphStage(const MapContext& ctx, MapWorker* worker) : ctx_(ctx), worker_(worker) {}

  // The pose graph a session's keyframes are in: kSharedGraph when it is aligned, else its
  // island's row (mapping lock held, or before the worker starts).
  int64_t GraphOf(int64_t session_row) const;
  // Mapping lock held: the verified matches of a keyframe of session query_session_row, into
  // the loop closer and the store.
  void RecordMatches(int64_t query_session_row, const std::vector<VerifiedMatch>& matches);
  // Stored matches into the loop closer (loading thread, while re-indexing); those found by a
  // keyframe in `unsolved` (keyframe id -> its graph) count towards that graph's next solve.
  void LoadPlaceMatches(const std::map<int64_t, int64_t>& unsolved);
  // Every stored keyframe's odometry is in the loop closer (after a start): solves may run.
  void SetIndexed(bool indexed) { indexed_ = indexed; }
  bool indexed() const { return indexed_; }
  // Without the mapping lock: solves the shared map's pose graph when due, then each island's
  // unless `keyframes_waiting` for place recognition (an unaligned robot's alignment comes
  // before its island's own loops). The lock is taken for the snapshot and to apply the
  // solution, not while solving.
  void MaybeCloseLoops(bool keyframes_waiting);

 private:
  // The graph whose next solve a match (candidate a_keyframe_id, found by a keyframe of
  // query_graph) counts towards.
  int64_t MatchGraph(int64_t a_keyframe_id, int64_t query_graph) const;
  void CloseLoops(MapInstance& target);
  // Moves the solved keyframes and those mapped during the solve, in chunks of
  // align.loops.apply_chunk_keyframes, each under the mapping lock. `map`: the target's map
  // the solve started from (a different one now: the solution is dropped).
  void ApplySolution(MapInstance& target, const std::shared_ptr<const Mapper>& map,
                     const SE3d& T_map_base, const std::vector<Mapper::KeyframePoseUpdate>& solved,
                     const GraphResult& result);
  // Mapping lock held: the solution's moves in `map`'s base frame, plus those of the keyframes
  // mapped during the solve (their number in *late_count).
  std::vector<Mapper::KeyframePoseUpdate> SolutionUpdates(
      const Mapper& map, const std::vector<Mapper::KeyframePoseUpdate>& solved,
      const GraphResult& result, size_t* late_count);
  // After a solve: each moved session's placement follows its newest mapped keyframe, so the
  // keyframes it sends next continue from the corrected pose. `mapped`: the keyframes the solve
  // saw (id order); `moved`: their corrected poses.
  void FollowCorrections(MapInstance& target,
                         const std::vector<Mapper::KeyframePoseUpdate>& mapped,
                         const std::vector<Mapper::KeyframePoseUpdate>& moved);

  MapContext ctx_;
  MapWorker* worker_;
  std::mutex close_loops_mu_;  // one solve at a time (aligning and loading threads)
  std::atomic<bool> indexed_{false};
};

}  // namespace loci::server
