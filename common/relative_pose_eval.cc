#include "common/relative_pose_eval.h"

#include <cmath>
#include <limits>

namespace loci {

RelativePoseErrors CompareRelativePoses(const Trajectory& sorted_gt,
                                        const std::vector<RelativePoseSample>& samples,
                                        int64_t offset_ns, int64_t max_gap_ns) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  RelativePoseErrors out;
  out.rot_deg.reserve(samples.size());
  out.trans_m.reserve(samples.size());
  for (const RelativePoseSample& s : samples) {
    const auto T_w_a = InterpolatePose(sorted_gt, s.a_t_ns + offset_ns, max_gap_ns);
    const auto T_w_b = InterpolatePose(sorted_gt, s.b_t_ns + offset_ns, max_gap_ns);
    if (!T_w_a || !T_w_b) {
      out.rot_deg.push_back(kNaN);
      out.trans_m.push_back(kNaN);
      continue;
    }
    const SE3d E = (T_w_a->inverse() * *T_w_b).inverse() * s.T_a_b;
    out.rot_deg.push_back(RotationAngleRad(E) * 180.0 / M_PI);
    out.trans_m.push_back(E.translation().norm());
  }
  return out;
}

}  // namespace loci
