// MapServer: loop closure and robot merges through the keyframe pose graph (server/align/
// loop_closer.h). The mapping worker records every keyframe's odometry, the aligning thread
// every verified place-recognition match (stored in `place_matches`); when enough new matches
// are in, the aligning thread solves the graph over a snapshot of the mapped keyframes in the
// map frame (z up: 4-DoF when gravity fixed it) without the mapping lock. Then each moved
// session's placement follows its newest keyframe, so the robot's own pose stream needs no
// change, and the moved keyframes are re-derived (Mapper::UpdateKeyframePoses, which emits the
// object events) in chunks, each under the mapping lock (chunked_move.h); those mapped during
// the solve follow their session (late_keyframes.h).
#include <spdlog/spdlog.h>

#include <chrono>
#include <map>

#include "common/malloc_tuning.h"
#include "server/service/chunked_move.h"
#include "server/service/late_keyframes.h"
#include "server/service/map_server.h"

namespace loci::server {

void MapServer::RecordForLoops(const MapperKeyframe& kf) {
  if (!closer_) return;
  closer_->AddKeyframe({kf.keyframe_id, kf.session_row, kf.segment, kf.t_ns, kf.T_odom_kf,
                        kf.tracking_inliers, kf.has_gravity ? kf.gravity_cam : Vec3d::Zero()});
}

void MapServer::RecordMatches(const std::vector<VerifiedMatch>& matches) {
  if (!closer_) return;
  closer_->NoteRecognised();
  for (const VerifiedMatch& m : matches) {
    closer_->AddMatch(m);
    const Status st = store_->PutPlaceMatch({m.a_id, m.b_id, m.T_a_b, m.inliers, m.rms_m});
    if (!st.ok()) {
      spdlog::warn("match of keyframes {} and {} not stored ({}); it is used until a restart",
                   m.a_id, m.b_id, st.ToString());
    }
  }
}

void MapServer::LoadPlaceMatches() {
  if (!closer_) return;
  auto matches = store_->ListPlaceMatches();
  if (!matches.ok()) {
    spdlog::warn("stored place matches not read ({}); loop closure starts without them",
                 matches.status().ToString());
    return;
  }
  for (const PlaceMatchRecord& m : *matches) {
    closer_->AddMatch({m.a_keyframe_id, m.b_keyframe_id, m.T_a_b, m.inliers, m.rms_m, false},
                      /*fresh=*/false);
  }
  if (!matches->empty()) spdlog::info("loop closure: {} stored matches", matches->size());
}

void MapServer::MaybeCloseLoops() {
  if (!closer_) return;
  // A snapshot of the mapped keyframes under mapping_mu_; the solve runs without it, so the
  // mapping worker goes on (a solve takes seconds at 10k keyframes). After a start the graph
  // waits for every stored keyframe's odometry (Reindex), and for the map frame, whose z the
  // 4-DoF solve holds.
  SE3d T_map_base;
  std::vector<Mapper::KeyframePoseUpdate> solved;
  bool gravity = false;
  {
    std::lock_guard<HandoffMutex> mapping(mapping_mu_);
    if (!reindexed_ || !closer_->Due() || !mapper_->FrameSettled()) return;
    T_map_base = mapper_->MapFromBaseFrame();
    solved = mapper_->KeyframePoses();
    gravity = mapper_->FrameSource().find("gravity") != std::string::npos;
  }
  std::vector<MappedKeyframe> mapped;
  mapped.reserve(solved.size());
  for (const Mapper::KeyframePoseUpdate& p : solved) {
    mapped.push_back({p.keyframe_id, T_map_base * p.T_base_kf});
  }
  auto result = closer_->Optimize(mapped, gravity);
  if (!result.ok()) {
    spdlog::warn("pose graph not solved: {}", result.status().ToString());
    return;
  }
  ApplySolution(T_map_base, solved, *result);
  ReleaseFreeHeapPages();  // the solve's graph (common/malloc_tuning.h)
}

// The lock is taken to check the frame, place the sessions and collect the moves, then for
// each chunk of the move (chunked_move.h).
void MapServer::ApplySolution(const SE3d& T_map_base,
                              const std::vector<Mapper::KeyframePoseUpdate>& solved,
                              const GraphResult& result) {
  auto same_frame = [&]() -> Status {
    if (mapper_->MapFromBaseFrame().matrix().isApprox(T_map_base.matrix(), 1e-12)) {
      return absl::OkStatus();
    }
    return absl::AbortedError("the map frame changed while the pose graph solved");
  };
  std::vector<Mapper::KeyframePoseUpdate> updates;
  size_t late = 0;
  {
    std::lock_guard<HandoffMutex> mapping(mapping_mu_);
    if (Status st = same_frame(); !st.ok()) {
      spdlog::warn("pose graph solution dropped: {}", st.ToString());
      return;
    }
    updates = SolutionUpdates(solved, result, &late);
    // Sessions are placed by the correction first: what the worker maps between two chunks is
    // mapped where the solution puts it.
    FollowCorrections(solved, updates);
  }
  const ChunkedMoveFigures moved = MoveInChunks(
      std::move(updates), static_cast<size_t>(options_.align.loops.apply_chunk_keyframes),
      mapping_mu_, same_frame,
      [this](const std::vector<Mapper::KeyframePoseUpdate>& chunk, bool last) {
        return UpdateKeyframePosesLocked(chunk, /*rebuild_octomap=*/last);
      });
  closer_->NoteApplied(moved.total_ms, moved.chunks, moved.longest_hold_ms);
  const GraphStats& g = result.stats;
  spdlog::info(
      "pose graph: {} keyframes, loops {} kept / {} rejected, merges {} kept / {} rejected, "
      "{} unconnected parts, {}{} gravity priors, guard {:.0f} ms + solve {:.0f} ms; {} keyframes "
      "moved ({} of them mapped during the solve) in {:.0f} ms, {} chunks, mapping paused at most "
      "{:.0f} ms",
      g.nodes, g.loops_accepted, g.loops_rejected, g.merges_accepted, g.merges_rejected,
      g.islands, g.four_dof ? "4-DoF, " : "", g.gravity_priors, g.pcm_ms, g.solve_ms,
      moved.moved, late, moved.total_ms, moved.chunks, moved.longest_hold_ms);
  if (!moved.status.ok()) {
    spdlog::warn("pose graph solution partly applied ({} keyframes moved): {}", moved.moved,
                 moved.status.ToString());
  }
}

std::vector<Mapper::KeyframePoseUpdate> MapServer::SolutionUpdates(
    const std::vector<Mapper::KeyframePoseUpdate>& solved, const GraphResult& result,
    size_t* late_count) {
  const SE3d T_base_map = mapper_->MapFromBaseFrame().inverse();
  std::vector<Mapper::KeyframePoseUpdate> updates;
  updates.reserve(result.updates.size());
  for (const KeyframePoseUpdate& u : result.updates) {
    updates.push_back({u.keyframe_id, T_base_map * u.T_map_kf});
  }
  // Keyframes mapped while the graph solved follow their session's correction.
  const std::vector<Mapper::KeyframePoseUpdate> late =
      LateKeyframeUpdates(solved, updates, mapper_->KeyframePoses(), [&](int64_t id) {
        const std::optional<LoopKeyframe> kf = closer_->Keyframe(id);
        return kf ? std::optional<int64_t>(kf->session_row) : std::nullopt;
      });
  *late_count = late.size();
  updates.insert(updates.end(), late.begin(), late.end());
  return updates;
}

void MapServer::FollowCorrections(const std::vector<Mapper::KeyframePoseUpdate>& mapped,
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
    std::optional<SessionRecord> s = SessionByRow(row);
    if (!s) continue;
    s->T_base_odom = it->second * last.second.inverse();
    aligner_->SetAlignment(row, s->T_base_odom);
    if (Status st = store_->SetSessionAlignment(row, s->T_base_odom); !st.ok()) {
      spdlog::warn("session {}: corrected placement not stored: {}", s->session_id, st.ToString());
    }
    SetSessionCache(*s);
  }
}

}  // namespace loci::server
