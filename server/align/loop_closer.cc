#include "server/align/loop_closer.h"

#include <absl/strings/str_cat.h>

#include <algorithm>
#include <chrono>

#include "server/graph/pose_graph.h"

namespace loci::server {
namespace {

std::string ChainName(int64_t session_row) { return absl::StrCat("s", session_row); }

TrackingQuality Quality(const LoopKeyframe& kf) {
  TrackingQuality q;
  if (kf.tracking_inliers > 0) q.inliers = kf.tracking_inliers;
  return q;
}

}  // namespace

LoopCloser::LoopCloser(const GraphOptions& graph, const LoopOptions& options)
    : graph_(graph), options_(options) {}

void LoopCloser::AddKeyframe(const LoopKeyframe& keyframe) {
  std::lock_guard<std::mutex> lock(mu_);
  keyframes_.try_emplace(keyframe.keyframe_id, keyframe);
}

void LoopCloser::AddMatch(const VerifiedMatch& match, bool fresh, int64_t graph) {
  std::lock_guard<std::mutex> lock(mu_);
  matches_[{match.a_id, match.b_id}] = match.T_a_b;
  if (!fresh) return;
  ++(match.loop ? stats_.loop_matches : stats_.merge_matches);
  ++pending_[graph].new_matches;
  pending_[graph].new_merges += !match.loop;
}

void LoopCloser::NoteRecognised(int64_t graph) {
  std::lock_guard<std::mutex> lock(mu_);
  ++pending_[graph].recognised;
}

bool LoopCloser::Due(int64_t graph, int64_t graph_keyframes) const {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = pending_.find(graph);
  if (it == pending_.end()) return false;
  const double size = graph_keyframes < 0 ? static_cast<double>(keyframes_.size())
                                          : static_cast<double>(graph_keyframes);
  const double min_keyframes =
      JoinDue(graph, it->second)
          ? options_.optimize_min_keyframes
          : std::max<double>(options_.optimize_min_keyframes, options_.optimize_growth * size);
  return it->second.new_matches >= options_.optimize_every_edges &&
         static_cast<double>(it->second.recognised) >= min_keyframes;
}

bool LoopCloser::JoinDue(int64_t graph, const Pending& pending) const {
  const auto parts = parts_.find(graph);
  return pending.new_merges > 0 && parts != parts_.end() && parts->second.count > 1 &&
         !parts->second.join_tried;
}

void LoopCloser::MoveDue(int64_t from, int64_t to) {
  if (from != to) {
    std::lock_guard<std::mutex> solving(solve_mu_);
    pcm_caches_.erase(from);
  }
  std::lock_guard<std::mutex> lock(mu_);
  stats_.islands.erase(from);
  if (from != to) parts_.erase(from);
  auto it = pending_.find(from);
  if (it == pending_.end() || from == to) return;
  Pending& dst = pending_[to];
  dst.new_matches += it->second.new_matches;
  dst.new_merges += it->second.new_merges;
  dst.recognised += it->second.recognised;
  pending_.erase(from);
}

std::optional<LoopKeyframe> LoopCloser::Keyframe(int64_t keyframe_id) const {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = keyframes_.find(keyframe_id);
  if (it == keyframes_.end()) return std::nullopt;
  return it->second;
}

LoopStats LoopCloser::Stats() const {
  std::lock_guard<std::mutex> lock(mu_);
  return stats_;
}

void LoopCloser::NoteIslandApplied(int64_t island, const GraphStats& solved) {
  std::lock_guard<std::mutex> lock(mu_);
  IslandGraphStats& stats = stats_.islands[island];
  ++stats.optimizations;
  stats.last = solved;
}

void LoopCloser::NoteApplied(double apply_ms, uint64_t chunks, double longest_hold_ms) {
  std::lock_guard<std::mutex> lock(mu_);
  stats_.last_apply_ms = apply_ms;
  stats_.last_apply_chunks = chunks;
  stats_.last_apply_longest_hold_ms = longest_hold_ms;
  stats_.longest_hold_ms = std::max(stats_.longest_hold_ms, longest_hold_ms);
}

StatusOr<GraphResult> LoopCloser::Optimize(const std::vector<MappedKeyframe>& mapped,
                                           bool gravity_aligned, int64_t graph_key,
                                           const std::vector<CentroidObservation>& centroids) {
  const auto t0 = std::chrono::steady_clock::now();
  std::lock_guard<std::mutex> solving(solve_mu_);
  PoseGraph graph(graph_);
  graph.SetPcmCache(&pcm_caches_[graph_key]);
  bool join = false;
  {
    std::lock_guard<std::mutex> lock(mu_);
    join = JoinDue(graph_key, pending_[graph_key]);
    pending_[graph_key] = Pending();
  }
  LOCI_RETURN_IF_ERROR(BuildGraph(mapped, gravity_aligned, centroids, &graph));
  // Without mu_: the mapping worker records keyframes and matches while the graph solves.
  LOCI_ASSIGN_OR_RETURN(GraphResult result, graph.Optimize());
  std::lock_guard<std::mutex> lock(mu_);
  Parts& parts = parts_[graph_key];
  parts.join_tried = join && result.stats.islands >= parts.count;
  parts.count = result.stats.islands;
  if (graph_key != kSharedGraph) return result;  // counted once applied (NoteIslandApplied)
  ++stats_.optimizations;
  stats_.keyframes_moved += result.updates.size();
  stats_.solve_ms_total +=
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  stats_.last = result.stats;
  return result;
}

Status LoopCloser::BuildGraph(const std::vector<MappedKeyframe>& mapped, bool gravity_aligned,
                              const std::vector<CentroidObservation>& centroids, PoseGraph* graph) {
  std::lock_guard<std::mutex> lock(mu_);
  // Nodes in id order: the first is the map's first keyframe (the gauge's reference chain).
  std::map<int64_t, const LoopKeyframe*> last_of_chain;  // by session row: the previous node
  std::map<int64_t, int64_t> session_of;                 // node id -> session row
  for (const MappedKeyframe& m : mapped) {
    auto it = keyframes_.find(m.keyframe_id);
    if (it == keyframes_.end()) continue;  // not recorded (its images could not be read)
    const LoopKeyframe& kf = it->second;
    LOCI_RETURN_IF_ERROR(graph->AddKeyframe({kf.keyframe_id, ChainName(kf.session_row), kf.t_ns,
                                             m.T_map_kf, gravity_aligned, -kf.gravity_kf}));
    session_of[kf.keyframe_id] = kf.session_row;
    const LoopKeyframe*& prev = last_of_chain[kf.session_row];
    if (prev != nullptr && prev->segment == kf.segment) {
      LOCI_RETURN_IF_ERROR(graph->AddOdometryEdge(prev->keyframe_id, kf.keyframe_id,
                                                  prev->T_odom_kf.inverse() * kf.T_odom_kf,
                                                  Quality(kf)));
    }
    prev = &kf;
  }
  const Information6 info = IsotropicInformation(options_.sigma_trans_m, options_.sigma_rot_rad);
  for (const auto& [ids, T_a_b] : matches_) {
    auto a = session_of.find(ids.first), b = session_of.find(ids.second);
    if (a == session_of.end() || b == session_of.end()) continue;  // not both mapped
    if (a->second == b->second) {
      LOCI_RETURN_IF_ERROR(graph->AddLoopEdge(ids.first, ids.second, T_a_b, info));
    } else {
      LOCI_RETURN_IF_ERROR(graph->AddMergeEdge(ids.first, ids.second, T_a_b, info));
    }
  }
  if (!graph_.landmarks.enabled) return absl::OkStatus();
  for (const CentroidObservation& c : centroids) {
    if (session_of.count(c.keyframe_id) == 0) continue;  // not in this graph
    LOCI_RETURN_IF_ERROR(graph->AddCentroidObservation(c));
  }
  return absl::OkStatus();
}

}  // namespace loci::server
