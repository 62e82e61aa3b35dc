#include "client/tracking/matcher.h"

#include <algorithm>
#include <climits>
#include <cmath>

namespace loci {

LOCI_POPCNT_CLONES void SearchByProjection(const OrbFrame& frame, const SE3d& T_cam_world,
                                           const PinholeCamera& cam,
                                           const std::vector<MapPoint*>& points,
                                           const ProjectionSearchParams& p, int64_t frame_index,
                                           std::vector<char>* kp_taken,
                                           std::vector<PointMatch>* matches) {
  // Best candidate per keypoint: index into `proposals`.
  std::vector<int> best_for_kp(frame.size(), -1);
  std::vector<PointMatch> proposals;
  std::vector<int> cand;
  const double log_sf = std::log(static_cast<double>(p.scale_factor));
  for (MapPoint* mp : points) {
    if (mp->last_search_frame == frame_index) continue;  // already matched in this frame
    const Vec3d pc = T_cam_world * mp->p_world;
    if (pc.z() < 0.05) continue;
    const auto uv = cam.Project(pc);
    if (!uv || !cam.InImage(*uv, 1.0)) continue;
    if (p.count_visible) ++mp->visible;
    const int pred = std::clamp(
        mp->octave + static_cast<int>(std::lround(std::log(mp->ref_depth_m / pc.z()) / log_sf)), 0,
        p.num_levels - 1);
    const double radius = p.radius_px * std::pow(p.scale_factor, pred);
    frame.FeaturesInRadius(uv->x(), uv->y(), radius, pred - 1, pred + 1, &cand);
    int best = INT_MAX, second = INT_MAX, best_kp = -1;
    for (int k : cand) {
      if ((*kp_taken)[k]) continue;
      const int d = Hamming(mp->descriptor, frame.descriptors[k]);
      if (d < best) {
        second = best;
        best = d;
        best_kp = k;
      } else if (d < second) {
        second = d;
      }
    }
    if (best_kp < 0 || best > p.max_hamming) continue;
    if (second != INT_MAX && best > p.ratio * second) continue;
    int& slot = best_for_kp[best_kp];
    if (slot >= 0 && proposals[slot].distance <= best) continue;
    if (slot >= 0) {
      proposals[slot].point = nullptr;  // displaced by a closer descriptor
    }
    slot = static_cast<int>(proposals.size());
    proposals.push_back({best_kp, mp, best});
  }
  for (const PointMatch& m : proposals) {
    if (!m.point) continue;
    (*kp_taken)[m.kp] = 1;
    m.point->last_search_frame = frame_index;
    matches->push_back(m);
  }
}

LOCI_POPCNT_CLONES std::vector<std::pair<int, int>> MatchBruteForce(const OrbFrame& frame,
                                                                    const OrbFrame& keyframe,
                                                                    int max_hamming, float ratio) {
  std::vector<std::pair<int, int>> out;
  std::vector<int> best_dist_for_kf(keyframe.size(), INT_MAX);
  std::vector<int> owner(keyframe.size(), -1);
  for (size_t i = 0; i < frame.size(); ++i) {
    int best = INT_MAX, second = INT_MAX, best_j = -1;
    for (size_t j = 0; j < keyframe.size(); ++j) {
      if (keyframe.depth_m[j] <= 0) continue;
      const int d = Hamming(frame.descriptors[i], keyframe.descriptors[j]);
      if (d < best) {
        second = best;
        best = d;
        best_j = static_cast<int>(j);
      } else if (d < second) {
        second = d;
      }
    }
    if (best_j < 0 || best > max_hamming || best > ratio * second) continue;
    if (best >= best_dist_for_kf[best_j]) continue;
    best_dist_for_kf[best_j] = best;
    owner[best_j] = static_cast<int>(i);
  }
  for (size_t j = 0; j < keyframe.size(); ++j) {
    if (owner[j] >= 0) out.emplace_back(owner[j], static_cast<int>(j));
  }
  return out;
}

}  // namespace loci
