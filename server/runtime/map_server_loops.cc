// MapServer: loop closure and robot merges through the keyframe pose graph (server/align/
// loop_closer.h). The mapping worker records every keyframe's odometry, the aligning thread
// every verified place-recognition match (stored in `place_matches`); when enough new matches
// are in, the aligning thread solves the graph over a snapshot of the mapped keyframes in the
// map frame (z up: 4-DoF when gravity fixed it) without the mapping lock. Then each moved
// session's placement follows its newest keyframe, so the robot's own pose stream needs no
// change, and the moved keyframes are re-derived (Mapper::UpdateKeyframePoses, which emits the
// object events) in chunks, each under the mapping lock (chunked_move.h); those mapped during
// the solve follow their session (late_keyframes.h).
//
// Each map island (an unaligned robot's own map, island_maps.h) has a graph of its own over its
// keyframes in its frame (LoopCloser's graph keyed by the island's row), solved and applied the
// same way: its sessions' T_island_odom follow their corrected newest keyframes, and its map is
// re-derived. The island's corrected poses are stored (in its frame), and a restart maps the
// island again at them; keyframes newer than its last solve at T_island_odom x odometry.
#include <spdlog/spdlog.h>

#include <chrono>
#include <map>

#include "common/malloc_tuning.h"
#include "server/runtime/chunked_move.h"
#include "server/runtime/late_keyframes.h"
#include "server/runtime/map_server.h"

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

void MapServer::RecordForLoops(const MapperKeyframe& kf) {
  if (!closer_) return;
  closer_->AddKeyframe({kf.keyframe_id, kf.session_row, kf.segment, kf.t_ns, kf.T_odom_kf,
                        kf.tracking_inliers, kf.has_gravity ? kf.gravity_cam : Vec3d::Zero()});
}

int64_t MapServer::GraphOf(int64_t session_row) const {
  if (aligner_->Alignment(session_row)) return kSharedGraph;
  return aligner_->IslandOf(session_row).first;
}

int64_t MapServer::MatchGraph(int64_t a_keyframe_id, int64_t query_graph) const {
  // The graph holding both keyframes; any other match (an unaligned robot's merge with an
  // aligned one, a join's) is the shared map's.
  const std::optional<LoopKeyframe> a = closer_->Keyframe(a_keyframe_id);
  return a && GraphOf(a->session_row) == query_graph ? query_graph : kSharedGraph;
}

void MapServer::RecordMatches(int64_t query_session_row,
                              const std::vector<VerifiedMatch>& matches) {
  if (!closer_) return;
  const int64_t query_graph = GraphOf(query_session_row);
  closer_->NoteRecognised(query_graph);
  for (const VerifiedMatch& m : matches) {
    closer_->AddMatch(m, /*fresh=*/true, MatchGraph(m.a_id, query_graph));
    const Status st = store_->PutPlaceMatch({m.a_id, m.b_id, m.T_a_b, m.inliers, m.rms_m});
    if (!st.ok()) {
      spdlog::warn("match of keyframes {} and {} not stored ({}); it is used until a restart",
                   m.a_id, m.b_id, st.ToString());
    }
  }
}


void MapServer::LoadPlaceMatches(const std::map<int64_t, int64_t>& unsolved) {
  if (!closer_) return;
  auto matches = store_->ListPlaceMatches();
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
    closer_->AddMatch({m.a_keyframe_id, m.b_keyframe_id, m.T_a_b, m.inliers, m.rms_m, false},
                      fresh, fresh ? MatchGraph(m.a_keyframe_id, it->second) : kSharedGraph);
    pending += fresh;
  }
  if (!matches->empty()) {
    spdlog::info("loop closure: {} stored matches, {} found since their graph's last solve",
                 matches->size(), pending);
  }
}

void MapServer::MaybeCloseLoops() {
  if (!closer_) return;
  CloseLoops(SharedTarget());
  // Islands wait while keyframes queue for place recognition: an unaligned robot's alignment
  // comes before its island's own loops (a solve of a 1000-keyframe island takes about 0.5 s).
  if (!islands_ || align_queue_.size() > 0) return;
  for (const IslandMaps::Island& island : islands_->List()) {
    CloseLoops(IslandTarget(island.session_row));
  }
}

MapServer::SolveTarget MapServer::SharedTarget() {
  SolveTarget t;
  t.graph = kSharedGraph;
  t.map = [this] {  // not owned: the server outlives its solves
    return std::shared_ptr<const Mapper>(std::shared_ptr<const Mapper>(), mapper_.get());
  };
  t.place = [this](int64_t row, const SE3d& T_base_odom) {
    std::optional<SessionRecord> s = sessions_.ByRow(row);
    if (!s) return;
    s->T_base_odom = T_base_odom;
    aligner_->SetAlignment(row, T_base_odom);
    if (Status st = store_->SetSessionAlignment(row, T_base_odom); !st.ok()) {
      spdlog::warn("session {}: corrected placement not stored: {}", s->session_id, st.ToString());
    }
    sessions_.Put(*s);
  };
  t.move = [this](const std::vector<Mapper::KeyframePoseUpdate>& chunk, bool last) {
    StatusOr<size_t> moved = UpdateKeyframePosesLocked(chunk, /*rebuild_octomap=*/last);
    // After the last chunk every keyframe's pose, those the solution left in place too (its
    // anchor): their session's placement has moved, so a replay from the first keyframe (no
    // usable checkpoint) would put them at the new placement x odometry.
    if (moved.ok() && last) {
      if (Status st = StoreCorrectedPoses(mapper_->KeyframePoses(), kSharedGraph); !st.ok()) {
        spdlog::warn("keyframe poses after the solve not all stored: {}", st.ToString());
      }
    }
    return moved;
  };
  return t;
}

MapServer::SolveTarget MapServer::IslandTarget(int64_t island_row) {
  SolveTarget t;
  t.graph = island_row;
  t.map = [this, island_row]() -> std::shared_ptr<const Mapper> {
    const std::optional<IslandMaps::Island> island = islands_->Find(island_row);
    return island ? island->map : nullptr;
  };
  t.place = [this, island_row](int64_t row, const SE3d& T_island_odom) {
    std::optional<SessionRecord> s = sessions_.ByRow(row);
    if (!s) return;
    s->island_row = island_row;
    s->T_island_odom = T_island_odom;
    aligner_->SetIsland(row, island_row, T_island_odom);
    if (Status st = store_->SetSessionIsland(row, island_row, T_island_odom); !st.ok()) {
      spdlog::warn("session {}: corrected island placement not stored: {}", s->session_id,
                   st.ToString());
    }
    sessions_.Put(*s);
  };
  t.move = [this, island_row](const std::vector<Mapper::KeyframePoseUpdate>& chunk, bool last) {
    StatusOr<size_t> moved =
        islands_->UpdateKeyframePoses(island_row, chunk, ProductsFromStore(), last);
    // After the last chunk every keyframe's pose in the island's frame, those the solution left
    // in place too (its anchor): their session's T_island_odom has moved, so a restart, which maps
    // the island again, would otherwise put them at the new placement x odometry.
    if (moved.ok() && last) StoreIslandPoses(island_row, island_row, SE3d::Identity());
    return moved;
  };
  return t;
}

// A snapshot of the target's mapped keyframes under mapping_mu_; the solve runs without it, so
// the mapping worker goes on (a solve takes seconds at 10k keyframes). After a start the graph
// waits for every stored keyframe's odometry (Reindex), and for the map frame, whose z the
// 4-DoF solve holds.
void MapServer::CloseLoops(const SolveTarget& target) {
  std::lock_guard<std::mutex> one_at_a_time(close_loops_mu_);
  std::shared_ptr<const Mapper> map;
  SE3d T_map_base;
  std::vector<Mapper::KeyframePoseUpdate> solved;
  std::vector<CentroidObservation> centroids;
  bool gravity = false;
  {
    std::lock_guard<FifoMutex> mapping(mapping_mu_);
    map = target.map();
    if (!map || !reindexed_ || !map->FrameSettled()) return;
    const int64_t size = target.graph == kSharedGraph
                             ? -1 : static_cast<int64_t>(map->KeyframeCount());
    if (!closer_->Due(target.graph, size)) return;
    T_map_base = map->MapFromBaseFrame();
    solved = map->KeyframePoses();
    if (options_.graph.landmarks.enabled) centroids = SeenCentroids(*map, options_.graph);
    gravity = map->FrameSource().find("gravity") != std::string::npos;
  }
  std::vector<MappedKeyframe> mapped;
  mapped.reserve(solved.size());
  for (const Mapper::KeyframePoseUpdate& p : solved) {
    mapped.push_back({p.keyframe_id, T_map_base * p.T_base_kf});
  }
  auto result = closer_->Optimize(mapped, gravity, target.graph, centroids);
  if (!result.ok()) {
    spdlog::warn("pose graph not solved: {}", result.status().ToString());
    return;
  }
  ApplySolution(target, map, T_map_base, solved, *result);
  ReleaseFreeHeapPages();  // the solve's graph (common/malloc_tuning.h)
}

// The lock is taken to check the frame, place the sessions and collect the moves, then for
// each chunk of the move (chunked_move.h).
void MapServer::ApplySolution(const SolveTarget& target, const std::shared_ptr<const Mapper>& map,
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
    std::lock_guard<FifoMutex> mapping(mapping_mu_);
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
      std::move(updates), static_cast<size_t>(options_.align.loops.apply_chunk_keyframes),
      mapping_mu_, same_frame, target.move);
  const GraphStats& g = result.stats;
  const std::string graph =
      target.graph == kSharedGraph ? "pose graph"
                                   : "island " + IslandName(target.graph) + "'s pose graph";
  if (target.graph == kSharedGraph) {
    closer_->NoteApplied(moved.total_ms, moved.chunks, moved.longest_hold_ms);
  } else {
    closer_->NoteIslandApplied(target.graph, result.stats);
  }
  spdlog::info(
      "{}: {} keyframes, loops {} kept / {} rejected, merges {} kept / {} rejected, "
      "{} unconnected parts, {}{} gravity priors, {} object landmarks ({} views), guard {:.0f} ms "
      "+ solve {:.0f} ms; {} keyframes moved ({} of them mapped during the solve) in {:.0f} ms, "
      "{} chunks, mapping paused at most {:.0f} ms",
      graph, g.nodes, g.loops_accepted, g.loops_rejected, g.merges_accepted, g.merges_rejected,
      g.islands, g.four_dof ? "4-DoF, " : "", g.gravity_priors, g.landmarks,
      g.centroid_observations, g.pcm_ms, g.solve_ms,
      moved.moved, late, moved.total_ms, moved.chunks, moved.longest_hold_ms);
  if (!moved.status.ok()) {
    spdlog::warn("{}: solution partly applied ({} keyframes moved): {}", graph, moved.moved,
                 moved.status.ToString());
  }
}

std::vector<Mapper::KeyframePoseUpdate> MapServer::SolutionUpdates(
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
        const std::optional<LoopKeyframe> kf = closer_->Keyframe(id);
        return kf ? std::optional<int64_t>(kf->session_row) : std::nullopt;
      });
  *late_count = late.size();
  updates.insert(updates.end(), late.begin(), late.end());
  return updates;
}

void MapServer::FollowCorrections(const SolveTarget& target,
                                  const std::vector<Mapper::KeyframePoseUpdate>& mapped,
                                  const std::vector<Mapper::KeyframePoseUpdate>& moved) {
  std::map<int64_t, SE3d> moved_by_id;
  for (const Mapper::KeyframePoseUpdate& u : moved) moved_by_id[u.keyframe_id] = u.T_base_kf;
  // The newest mapped keyframe of every session (`mapped` is in id order).
  std::map<int64_t, std::pair<int64_t, SE3d>> newest;  // session row -> (id, T_odom_kf)
  for (const Mapper::KeyframePoseUpdate& p : mapped) {
    const std::optional<LoopKeyframe> kf = closer_->Keyframe(p.keyframe_id);
    if (kf) newest[kf->session_row] = {kf->keyframe_id, kf->T_odom_kf};
  }
  for (const auto& [row, last] : newest) {
    auto it = moved_by_id.find(last.first);
    if (it == moved_by_id.end()) continue;
    target.place(row, it->second * last.second.inverse());
  }
}

}  // namespace loci::server
