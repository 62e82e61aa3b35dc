// Relative poses between two instants (a verified loop match's T_a_b, the odometry's between the
// same two keyframes) against a ground-truth trajectory: how far each is from the truth's.
// `loci eval loops` uses it to weigh a session's loop matches against its odometry.
#pragma once

#include <cstdint>
#include <vector>

#include "common/se3.h"
#include "common/tum_io.h"

namespace loci {

// A relative pose measured between the camera at a_t_ns and at b_t_ns (p_a = T_a_b * p_b).
struct RelativePoseSample {
  int64_t a_t_ns = 0;
  int64_t b_t_ns = 0;
  SE3d T_a_b = SE3d::Identity();
};

// Per sample, in order: the rotation (deg) and translation (m) of T_true_a_b^-1 * T_a_b; NaN
// where the truth has no pose at either instant (InterpolatePose, max_gap_ns).
struct RelativePoseErrors {
  std::vector<double> rot_deg;
  std::vector<double> trans_m;
};

// The truth is read at each stamp + offset_ns (an image clock's offset to the ground truth's).
RelativePoseErrors CompareRelativePoses(const Trajectory& sorted_gt,
                                        const std::vector<RelativePoseSample>& samples,
                                        int64_t offset_ns, int64_t max_gap_ns);

}  // namespace loci
