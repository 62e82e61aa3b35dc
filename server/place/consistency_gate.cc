#include "server/place/consistency_gate.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace loci::place {

SE3d MeanTransform(const std::vector<SE3d>& transforms) {
  if (transforms.empty()) return SE3d::Identity();
  Vec3d t = Vec3d::Zero();
  Eigen::Vector4d q_sum = Eigen::Vector4d::Zero();
  const Quatd q0 = QuatOf(transforms.front());
  for (const SE3d& T : transforms) {
    t += T.translation();
    Quatd q = QuatOf(T);
    if (q.dot(q0) < 0) q.coeffs() = -q.coeffs();
    q_sum += q.coeffs();
  }
  Quatd q_mean;
  q_mean.coeffs() = q_sum.normalized();
  return MakeSE3(t / static_cast<double>(transforms.size()), q_mean);
}

bool ConsistencyGate::Agree(const SE3d& a, const SE3d& b) const {
  const SE3d d = a.inverse() * b;
  return d.translation().norm() <= options_.max_translation_m &&
         RotationAngleRad(d) <= options_.max_rotation_deg * std::numbers::pi / 180.0;
}

int ConsistencyGate::Pending(const std::string& hypothesis) const {
  const auto it = pending_.find(hypothesis);
  return it == pending_.end() ? 0 : static_cast<int>(it->second.size());
}

ConsistencyGate::Decision ConsistencyGate::Add(const std::string& hypothesis, int64_t keyframe_id,
                                               const SE3d& T_x_y) {
  std::vector<Estimate>& collected = pending_[hypothesis];
  Decision decision;
  const bool seen = std::any_of(collected.begin(), collected.end(),
                                [&](const Estimate& e) { return e.keyframe_id == keyframe_id; });
  if (seen) {
    decision.verdict = Verdict::kDuplicate;
    decision.agreeing = static_cast<int>(collected.size());
    return decision;
  }
  const bool agrees = std::all_of(collected.begin(), collected.end(),
                                  [&](const Estimate& e) { return Agree(e.T_x_y, T_x_y); });
  if (!agrees) {
    collected.clear();
    decision.verdict = Verdict::kReset;
  }
  collected.push_back({keyframe_id, T_x_y});
  decision.agreeing = static_cast<int>(collected.size());
  if (decision.agreeing >= options_.min_matches) {
    std::vector<SE3d> all;
    for (const Estimate& e : collected) all.push_back(e.T_x_y);
    decision.verdict = Verdict::kAccepted;
    decision.T_x_y = MeanTransform(all);
    pending_.erase(hypothesis);
  }
  return decision;
}

}  // namespace loci::place
