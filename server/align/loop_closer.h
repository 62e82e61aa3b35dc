// Loop closure and robot merges through the keyframe pose graph: collects
// every mapped keyframe's odometry and every verified place-recognition match (robot_aligner.h),
// and, when enough new matches are in, builds a PoseGraph (server/graph/) over the mapped
// keyframes and solves it. The caller moves the map to the solution (Mapper::UpdateKeyframePoses).
//
//   nodes     every mapped keyframe that was recorded, at its current map pose (the warm start);
//             one odometry chain per session ("s<row>") and odometry segment;
//   odometry  consecutive recorded keyframes of one session and segment: T_odom_a^-1 T_odom_b,
//             weighed by b's tracking inliers when the client sent them;
//   loops     verified matches within a session, merges between sessions, isotropic
//             information from align.loops.sigma_*; the graph's guard (PCM, residual check,
//             robust loss) decides which it trusts.
//
// One recorder serves several graphs: the shared map's (kSharedGraph) and one per map island
// (keyed by the island's row: an unaligned robot's loops are closed in its island's frame). A
// graph is the records restricted to the keyframes the caller passes; each graph counts its own
// new matches towards its next solve. When an island is aligned or joins another, its pending
// count moves to the graph it became part of (MoveDue), and its edges are there already.
//
// The graph is rebuilt from these records on every solve, so what was stored (odometry in
// `keyframes`, matches in `place_matches`) is all a restart needs. The only state kept between
// solves is the guard's pairwise results (server/graph/pcm_cache.h, one cache per graph), which
// gives the same selection as testing every pair again; a restart tests every pair once.
// Thread-safe: the mapping worker records, the aligning thread solves, GetStats reads Stats().
#pragma once

#include <cstdint>
#include <map>
#include <mutex>
#include <optional>
#include <utility>
#include <vector>

#include "common/status.h"
#include "server/align/align_options.h"
#include "server/align/robot_aligner.h"
#include "server/graph/graph_options.h"
#include "server/graph/graph_types.h"
#include "server/graph/pcm_cache.h"

namespace loci::server {

class PoseGraph;

struct LoopKeyframe {
  int64_t keyframe_id = 0;
  int64_t session_row = 0;
  int segment = 0;  // the client's odometry segment (a tracking loss starts a new one)
  int64_t t_ns = 0;
  SE3d T_odom_kf = SE3d::Identity();
  int tracking_inliers = 0;          // the client's tracking quality of T_odom_kf (0 = unknown)
  Vec3d gravity_kf = Vec3d::Zero();  // the keyframe's measured gravity, unit, down (0: none)
};

// A mapped keyframe's current pose in the map frame.
struct MappedKeyframe {
  int64_t keyframe_id = 0;
  SE3d T_map_kf = SE3d::Identity();
};

// An island's latest solve (LoopStats::islands).
struct IslandGraphStats {
  uint64_t optimizations = 0;  // solves of the island's graph applied to its map since start
  GraphStats last;
};

struct LoopStats {
  uint64_t loop_matches = 0;     // verified matches recorded, within one session
  uint64_t merge_matches = 0;    // between two sessions
  uint64_t optimizations = 0;    // solves run
  uint64_t keyframes_moved = 0;  // summed over the solves
  double solve_ms_total = 0;     // PCM + Ceres, wall ms, summed
  GraphStats last;               // of the latest solve
  // Moving the map to the latest solution (in chunks, MapServer): wall ms from the first chunk
  // to the last, chunks, and the longest the mapping lock was held for one chunk; the longest
  // such hold since start.
  double last_apply_ms = 0;
  uint64_t last_apply_chunks = 0;
  double last_apply_longest_hold_ms = 0;
  double longest_hold_ms = 0;
  // The figures above (optimizations, last, solve time, keyframes moved) are the shared map's;
  // each island's solves are counted here, by island row.
  std::map<int64_t, IslandGraphStats> islands;
};

class LoopCloser {
 public:
  LoopCloser(const GraphOptions& graph, const LoopOptions& options);

  // Records a keyframe's odometry (once per id; later calls are ignored).
  void AddKeyframe(const LoopKeyframe& keyframe);
  // Records a verified match; a pair recorded again replaces the earlier one. `fresh`: found
  // now (counts towards `graph`'s Due), not reloaded from the store.
  void AddMatch(const VerifiedMatch& match, bool fresh = true, int64_t graph = kSharedGraph);
  // A keyframe of `graph` went through place recognition (counts towards optimize_min_keyframes).
  void NoteRecognised(int64_t graph = kSharedGraph);
  // Whether a solve of `graph` is due: optimize_every_edges new matches and
  // max(optimize_min_keyframes, optimize_growth x graph_keyframes) keyframes through place
  // recognition since its last solve. Counted in keyframes, not time, so the same
  // data gives the same solves and the same map. graph_keyframes < 0: every recorded keyframe.
  // When the last solve left the graph in unconnected parts (a robot aligned before its merge
  // edges were in) and merge matches have come since, optimize_min_keyframes is enough: the
  // parts are joined now, not after the graph has grown by its share. Once per part count: a
  // solve that joins nothing does not make the next one early.
  bool Due(int64_t graph = kSharedGraph, int64_t graph_keyframes = -1) const;
  // `from`'s pending matches and keyframes count for `to` from now on (an island aligned to the
  // shared map, or joined to another island); `from`'s counts and stats are dropped.
  void MoveDue(int64_t from, int64_t to);

  // Builds `graph`'s graph over `mapped` (map frame, or the island's frame; all z up from
  // gravity when `gravity_aligned`) and solves it, with the objects' centroids as the mapped
  // keyframes saw them as landmarks when graph.landmarks.enabled (those of other keyframes are
  // left out). The updates are the keyframes that moved (T_map_kf). Resets Due(graph). One
  // solve at a time; recording goes on while it solves (only the build holds the records).
  StatusOr<GraphResult> Optimize(const std::vector<MappedKeyframe>& mapped, bool gravity_aligned,
                                 int64_t graph = kSharedGraph,
                                 const std::vector<CentroidObservation>& centroids = {});

  LoopStats Stats() const;
  // Records that a solve of island graph `island` was applied to its map (LoopStats::islands).
  void NoteIslandApplied(int64_t island, const GraphStats& solved);
  // Records how the latest solution was moved into the map (LoopStats' apply figures).
  void NoteApplied(double apply_ms, uint64_t chunks, double longest_hold_ms);
  std::optional<LoopKeyframe> Keyframe(int64_t keyframe_id) const;

 private:
  GraphOptions graph_;
  LoopOptions options_;
  // The graph over the records (mu_ held by the caller's lock inside).
  Status BuildGraph(const std::vector<MappedKeyframe>& mapped, bool gravity_aligned,
                    const std::vector<CentroidObservation>& centroids, PoseGraph* graph);
  // What counts towards a graph's next solve.
  struct Pending {
    int new_matches = 0;
    int new_merges = 0;  // of new_matches, between sessions
    int recognised = 0;
  };
  // A graph's connected parts after its last solve, and whether an early solve to join them
  // (Due) found nothing to join.
  struct Parts {
    size_t count = 1;
    bool join_tried = false;
  };
  // Whether `graph`'s next solve may join its parts early (mu_ held).
  bool JoinDue(int64_t graph, const Pending& pending) const;

  mutable std::mutex mu_;                      // the records and stats
  std::map<int64_t, Parts> parts_;             // by graph (mu_)
  std::mutex solve_mu_;                        // one solve at a time; guards pcm_cache_
  std::map<int64_t, LoopKeyframe> keyframes_;  // by id
  // T_a_b by (a, b); loop or merge is decided by the keyframes' sessions when solving.
  std::map<std::pair<int64_t, int64_t>, SE3d> matches_;
  std::map<int64_t, Pending> pending_;  // by graph
  LoopStats stats_;
  std::map<int64_t, PcmCache> pcm_caches_;  // by graph; solve_mu_
};

}  // namespace loci::server
