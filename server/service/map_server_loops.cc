// MapServer: loop closure and robot merges through the keyframe pose graph (server/align/
// loop_closer.h). The mapping worker records every keyframe's odometry, the aligning thread
// every verified place-recognition match (stored in `place_matches`); when enough new matches
// are in, the
// graph over the mapped keyframes is solved in the map frame (z up: 4-DoF when gravity fixed
// it), the moved keyframes are re-derived (Mapper::UpdateKeyframePoses, which emits the object
// events), and each moved session's placement follows its newest keyframe, so the robot's own
// pose stream needs no change.
#include <spdlog/spdlog.h>

#include <chrono>
#include <map>

#include "common/malloc_tuning.h"
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
  // After a start the graph waits for every stored keyframe's odometry (Reindex), and for the
  // map frame, whose z the 4-DoF solve holds.
  if (!closer_ || !reindexed_ || !closer_->Due() || !mapper_->FrameSettled()) return;
  const SE3d T_map_base = mapper_->MapFromBaseFrame();
  const std::vector<Mapper::KeyframePoseUpdate> poses = mapper_->KeyframePoses();
  std::vector<MappedKeyframe> mapped;
  mapped.reserve(poses.size());
  for (const Mapper::KeyframePoseUpdate& p : poses) {
    mapped.push_back({p.keyframe_id, T_map_base * p.T_base_kf});
  }
  const bool gravity = mapper_->FrameSource().find("gravity") != std::string::npos;
  auto result = closer_->Optimize(mapped, gravity);
  if (!result.ok()) {
    spdlog::warn("pose graph not solved: {}", result.status().ToString());
    return;
  }
  const GraphStats& g = result->stats;
  std::vector<Mapper::KeyframePoseUpdate> updates;
  updates.reserve(result->updates.size());
  const SE3d T_base_map = T_map_base.inverse();
  for (const KeyframePoseUpdate& u : result->updates) {
    updates.push_back({u.keyframe_id, T_base_map * u.T_map_kf});
  }
  const auto t0 = std::chrono::steady_clock::now();
  auto moved = updates.empty() ? StatusOr<size_t>(0) : UpdateKeyframePosesLocked(updates);
  spdlog::info(
      "pose graph: {} keyframes, loops {} kept / {} rejected, merges {} kept / {} rejected, "
      "{} unconnected parts, {}{} gravity priors, guard {:.0f} ms + solve {:.0f} ms; {} keyframes "
      "moved in {:.0f} ms",
      g.nodes, g.loops_accepted, g.loops_rejected, g.merges_accepted, g.merges_rejected,
      g.islands, g.four_dof ? "4-DoF, " : "", g.gravity_priors, g.pcm_ms, g.solve_ms,
      moved.ok() ? *moved : 0,
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  if (!moved.ok()) {
    spdlog::warn("pose graph solution not applied: {}", moved.status().ToString());
    return;
  }
  FollowCorrections(poses, updates);
  ReleaseFreeHeapPages();  // the solve's graph (common/malloc_tuning.h)
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
