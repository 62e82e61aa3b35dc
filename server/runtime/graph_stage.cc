#include "server/runtime/graph_stage.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <map>

#include "common/malloc_tuning.h"
#include "server/runtime/chunked_move.h"
#include "server/runtime/late_keyframes.h"

namespace loci::server {
namespace {

// The map's objects as each keyframe saw them: the pose graph's landmarks (graph.landmarks).
std::vector<CentroidObservation> SeenCentroids(const Mapper& map, const GraphOptions& graph) {
  std::vector<CentroidObservation> out;
  for (const Mapper::SeenCentroid& c : map.SeenCentroids(graph.landmarks.max_object_size_m)) {
    out.push_back({c.keyframe_id, c.object_id, c.c_kf_m});
  }
  return out;
}

}  // namespace

int64_t GraphStage::GraphOf(int64_t session_row) const {
  if (ctx_.aligner->Alignment(session_row)) return kSharedGraph;
  return ctx_.aligner->IslandOf(session_row).first;
}

int64_t GraphStage::MatchGraph(int64_t a_keyframe_id, int64_t query_graph) const {
  // The graph holding both keyframes; any other match (an unaligned robot's merge with an
  // aligned one, a join's) is the shared map's.
  const std::optional<LoopKeyframe> a = ctx_.closer->Keyframe(a_keyframe_id);
  return a && GraphOf(a->session_row) == query_graph ? query_graph : kSharedGraph;
}

void GraphStage::RecordMatches(int64_t query_session_row,
                               const std::vector<VerifiedMatch>& matches) {
  if (!ctx_.closer) return;
  const int64_t query_graph = GraphOf(query_session_row);
  ctx_.closer->NoteRecognised(query_graph);
  for (const VerifiedMatch& m : matches) {
    ctx_.closer->AddMatch(m, /*fresh=*/true, MatchGraph(m.a_id, query_graph));
    const Status st = ctx_.store.PutPlaceMatch({m.a_id, m.b_id, m.T_a_b, m.inliers, m.rms_m});
    if (!st.ok()) {
      spdlog::warn("match of keyframes {} and {} not stored ({}); it is used until a restart",
                   m.a_id, m.b_id, st.ToString());
    }
  }
}

void GraphStage::LoadPlaceMatches(const std::map<int64_t, int64_t>& unsolved) {
  if (!ctx_.closer) return;
  auto matches = ctx_.store.ListPlaceMatches();
  if (!matches.ok()) {
    spdlog::warn("stored place matches not read ({}); loop closure starts without them",
                 matches.status().ToString());
    return;
  }
  size_t pending = 0;
  for (const PlaceMatchRecord& m : *matches) {
    // A match found by a keyframe that no solve has placed since counts towards its graph's next
    // solve, as it did before the restart (RecordMatches).
    auto it = unsolved.find(m.b_keyframe_id);
    const bool fresh = it != unsolved.end();
    ctx_.closer->AddMatch({m.a_keyframe_id, m.b_keyframe_id, m.T_a_b, m.inliers, m.rms_m, false},
                          fresh, fresh ? MatchGraph(m.a_keyframe_id, it->second) : kSharedGraph);
    pending += fresh;
  }
  if (!matches->empty()) {
    spdlog::info("loop closure: {} stored matches, {} found since their graph's last solve",
                 matches->size(), pending);
  }
}

void GraphStage::MaybeCloseLoops(bool keyframes_waiting) {
  if (!ctx_.closer) return;
  CloseLoops(*SharedMapInstance(ctx_, worker_));
  // A solve of a 1000-keyframe island takes about 0.5 s.
  if (!ctx_.islands || keyframes_waiting) return;
  for (const IslandMaps::Island& island : ctx_.islands->List()) {
    CloseLoops(*IslandInstance(ctx_, worker_, island.session_row));
  }
}

// A snapshot of the target's mapped keyframes under the mapping lock; the solve runs without
// it, so the mapping worker goes on (a solve takes seconds at 10k keyframes). After a start the
// graph waits for every stored keyframe's odometry (the re-index), and for the map frame, whose
// z the 4-DoF solve holds.
void GraphStage::CloseLoops(MapInstance& target) {
  std::lock_guard<std::mutex> one_at_a_time(close_loops_mu_);
  std::shared_ptr<const Mapper> map;
  SE3d T_map_base;
  std::vector<Mapper::KeyframePoseUpdate> solved;
  std::vector<CentroidObservation> centroids;
  bool gravity = false;
  {
    std::lock_guard<FifoMutex> mapping(worker_->mapping_mutex());
    map = target.map();
    if (!map || !indexed_ || !map->FrameSettled()) return;
    const int64_t size =
        target.graph() == kSharedGraph ? -1 : static_cast<int64_t>(map->KeyframeCount());
    if (!ctx_.closer->Due(target.graph(), size)) return;
    T_map_base = map->MapFromBaseFrame();
    solved = map->KeyframePoses();
    if (ctx_.options.graph.landmarks.enabled) centroids = SeenCentroids(*map, ctx_.options.graph);
    gravity = map->FrameSource().find("gravity") != std::string::npos;
  }
  std::vector<MappedKeyframe> mapped;
  mapped.reserve(solved.size());
  for (const Mapper::KeyframePoseUpdate& p : solved) {
    mapped.push_back({p.keyframe_id, T_map_base * p.T_base_kf});
  }
  auto result = ctx_.closer->Optimize(mapped, gravity, target.graph(), centroids);
  if (!result.ok()) {
    spdlog::warn("pose graph not solved: {}", result.status().ToString());
    return;
  }
  ApplySolution(target, map, T_map_base, solved, *result);
  ReleaseFreeHeapPages();  // the solve's graph (common/malloc_tuning.h)
}

// The lock is taken to check the frame, place the sessions and collect the moves, then for
// each chunk of the move (chunked_move.h).
void GraphStage::ApplySolution(MapInstance& target, const std::shared_ptr<const Mapper>& map,
                               const SE3d& T_map_base,
                               const std::vector<Mapper::KeyframePoseUpdate>& solved,
                               const GraphResult& result) {
  auto same_frame = [&]() -> Status {
    if (target.map() != map) {
      return absl::AbortedError("the island was aligned or joined another while its graph solved");
    }
    if (map->MapFromBaseFrame().matrix().isApprox(T_map_base.matrix(), 1e-12)) {
      return absl::OkStatus();
    }
    return absl::AbortedError("the map frame changed while the pose graph solved");
  };
  std::vector<Mapper::KeyframePoseUpdate> updates;
  size_t late = 0;
  {
    std::lock_guard<FifoMutex> mapping(worker_->mapping_mutex());
    if (Status st = same_frame(); !st.ok()) {
      spdlog::warn("pose graph solution dropped: {}", st.ToString());
      return;
    }
    updates = SolutionUpdates(*map, solved, result, &late);
    // Sessions are placed by the correction first: what the worker maps between two chunks is
    // mapped where the solution puts it.
    FollowCorrections(target, solved, updates);
  }
  const ChunkedMoveFigures moved = MoveInChunks(
      std::move(updates), static_cast<size_t>(ctx_.options.align.loops.apply_chunk_keyframes),
      worker_->mapping_mutex(), same_frame,
      [&](const std::vector<Mapper::KeyframePoseUpdate>& chunk, bool last) {
        return target.Move(chunk, last);
      });
  const GraphStats& g = result.stats;
  const bool shared = target.graph() == kSharedGraph;
  const std::string graph =
      shared ? "pose graph" : "island " + worker_->IslandName(target.graph()) + "'s pose graph";
  if (shared) {
    ctx_.closer->NoteApplied(moved.total_ms, moved.chunks, moved.longest_hold_ms);
  } else {
    ctx_.closer->NoteIslandApplied(target.graph(), result.stats);
  }
  spdlog::info(
      "{}: {} keyframes, loops {} kept / {} rejected, merges {} kept / {} rejected, "
      "{} unconnected parts, {}{} gravity priors, {} object landmarks ({} views), guard {:.0f} ms "
      "+ solve {:.0f} ms; {} keyframes moved ({} of them mapped during the solve) in {:.0f} ms, "
      "{} chunks, mapping paused at most {:.0f} ms",
      graph, g.nodes, g.loops_accepted, g.loops_rejected, g.merges_accepted, g.merges_rejected,
      g.islands, g.four_dof ? "4-DoF, " : "", g.gravity_priors, g.landmarks,
      g.centroid_observations, g.pcm_ms, g.solve_ms, moved.moved, late, moved.total_ms,
      moved.chunks, moved.longest_hold_ms);
  if (!moved.status.ok()) {
    spdlog::warn("{}: solution partly applied ({} keyframes moved): {}", graph, moved.moved,
                 moved.status.ToString());
  }
}

std::vector<Mapper::KeyframePoseUpdate> GraphStage::SolutionUpdates(
    const Mapper& map, const std::vector<Mapper::KeyframePoseUpdate>& solved,
    const GraphResult& result, size_t* late_count) {
  const SE3d T_base_map = map.MapFromBaseFrame().inverse();
  std::vector<Mapper::KeyframePoseUpdate> updates;
  updates.reserve(result.updates.size());
  for (const KeyframePoseUpdate& u : result.updates) {
    updates.push_back({u.keyframe_id, T_base_map * u.T_map_kf});
  }
  // Keyframes mapped while the graph solved follow their session's correction.
  const std::vector<Mapper::KeyframePoseUpdate> late =
      LateKeyframeUpdates(solved, updates, map.KeyframePoses(), [&](int64_t id) {
        const std::optional<LoopKeyframe> kf = ctx_.closer->Keyframe(id);
        return kf ? std::optional<int64_t>(kf->session_row) : std::nullopt;
      });
  *late_count = late.size();
  updates.insert(updates.end(), late.begin(), late.end());
  return updates;
}

void GraphStage::FollowCorrections(MapInstance& target,
                                   const std::vector<Mapper::KeyframePoseUpdate>& mapped,
                                   const std::vector<Mapper::KeyframePoseUpdate>& moved) {
  std::map<int64_t, SE3d> moved_by_id;
  for (const Mapper::KeyframePoseUpdate& u : moved) moved_by_id[u.keyframe_id] = u.T_base_kf;
  // The newest mapped keyframe of every session (`mapped` is in id order).
  std::map<int64_t, std::pair<int64_t, SE3d>> newest;  // session row -> (id, T_odom_kf)
  for (const Mapper::KeyframePoseUpdate& p : mapped) {
    const std::optional<LoopKeyframe> kf = ctx_.closer->Keyframe(p.keyframe_id);
    if (kf) newest[kf->session_row] = {kf->keyframe_id, kf->T_odom_kf};
  }
  for (const auto& [row, last] : newest) {
    auto it = moved_by_id.find(last.first);
    if (it == moved_by_id.end()) continue;
    target.Place(row, it->second * last.second.inverse());
  }
}

}  // namespace loci::server
