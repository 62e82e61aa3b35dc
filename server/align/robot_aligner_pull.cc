// RobotAligner::Pull: an aligned robot's keyframe that matches an unaligned island's places
// brings the island into the shared map (robot_aligner.h).
#include <absl/strings/str_cat.h>
#include <spdlog/spdlog.h>

#include <set>

#include "server/align/robot_aligner.h"

namespace loci::server {

std::vector<SessionAlignment> RobotAligner::Pull(const AlignKeyframe& kf,
                                                 const std::vector<VerifiedMatch>& matches) {
  const std::optional<SE3d> T_base_odom_b = Alignment(kf.session_row);
  if (!T_base_odom_b) return {};
  const SE3d T_base_kf_b = *T_base_odom_b * kf.T_odom_kf;
  std::set<int64_t> estimated;  // one estimate per island and keyframe: its best-ranked match
  std::vector<SessionAlignment> out;
  uint64_t pulled = 0;
  for (const VerifiedMatch& m : matches) {
    const IndexedKeyframe& a = indexed_.at(m.a_id);
    if (m.loop || Alignment(a.session_row)) continue;
    const auto [island, T_island_odomA] = IslandOf(a.session_row);
    if (!estimated.insert(island).second) continue;
    const SE3d T_island_kf_a = MappedPose(m.a_id, a, island, T_island_odomA);
    const place::ConsistencyGate::Decision d =
        gate_.Add(absl::StrCat("pull", island), kf.keyframe_id,
                  T_base_kf_b * m.T_a_b.inverse() * T_island_kf_a.inverse());
    if (d.verdict != place::ConsistencyGate::Verdict::kAccepted) continue;
    ++pulled;
    std::lock_guard<std::mutex> lock(sessions_mu_);
    SE3d T_base_island = d.T_x_y;
    const auto [down_island, n_island] = IslandDown(island);
    const auto [down_base, n_base] = BaseDown();
    const bool levelled = options_.level_with_gravity &&
                          n_island >= options_.min_gravity_keyframes &&
                          n_base >= options_.min_gravity_keyframes;
    if (levelled) {
      T_base_island = LevelOnto(T_base_island, down_island, down_base,
                                T_base_island * T_island_kf_a.translation());
    }
    for (auto& [row, s] : sessions_) {
      if (s.T_base_odom || IslandOfLocked(row).first != island) continue;
      s.T_base_odom = T_base_island * IslandOfLocked(row).second;
      s.recognised = true;
      s.delay = AlignmentDelay{s.keyframes,
                               1e-9 * static_cast<double>(s.last_t_ns - s.first_t_ns)};
      out.push_back({row, *s.T_base_odom, kf.keyframe_id, d.agreeing, levelled, false});
    }
    spdlog::info("island {} aligned by keyframe {} of session row {} ({} agreeing matches{})",
                 island, kf.keyframe_id, kf.session_row, d.agreeing,
                 levelled ? ", levelled with gravity" : "");
  }
  if (pulled > 0) {
    std::lock_guard<std::mutex> stats(stats_mu_);
    stats_.merges_accepted += pulled;
    stats_.islands_pulled += pulled;
  }
  return out;
}

}  // namespace loci::server
