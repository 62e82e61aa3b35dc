// RobotAligner::QueryAhead: an unaligned robot's newest keyframe matched against the shared map
// before the backlog queued ahead of it is worked through (robot_aligner.h).
#include "common/time.h"
#include "server/align/robot_aligner.h"

namespace loci::server {

StatusOr<AlignOutcome> RobotAligner::QueryAhead(const AlignKeyframe& kf, const cv::Mat& bgr,
                                                const cv::Mat& depth_m,
                                                const PinholeCamera& camera) {
  const double t0_ms = ThreadCpuMs();
  std::lock_guard<std::mutex> work(work_mu_);
  AlignOutcome out;
  if (indexed_.count(kf.keyframe_id)) return out;
  {
    std::lock_guard<std::mutex> lock(sessions_mu_);
    auto it = sessions_.find(kf.session_row);
    if (it == sessions_.end() || it->second.T_base_odom) return out;
  }
  // Words are added when AddKeyframe indexes it: the vocabulary grows in keyframe order.
  LOCI_ASSIGN_OR_RETURN(const Described q,
                        Describe(bgr, depth_m, camera, /*add_words=*/false, /*dense=*/true));
  out.matches = Match(kf, q.features, q.bow, /*loops=*/false, /*query_aligned=*/false,
                      q.dense.get(), /*aligned_only=*/true);
  out.alignment = Gate(kf, Estimates(kf, out.matches), /*counted=*/false);
  if (out.alignment) out.island_alignments = AlignIsland(*out.alignment);
  std::lock_guard<std::mutex> lock(stats_mu_);
  ++stats_.queries_ahead;
  stats_.place_ms_total += ThreadCpuMs() - t0_ms;
  if (out.alignment) {
    ++stats_.merges_accepted;
    ++stats_.merges_ahead;
  }
  return out;
}

}  // namespace loci::server
