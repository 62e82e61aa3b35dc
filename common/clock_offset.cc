#include "common/clock_offset.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include "common/trajectory_eval.h"

namespace loci {
namespace {

// Ground-truth orientations at each estimate stamp + offset; nullopt where gt has none.
std::vector<std::optional<Mat3d>> GtRotations(const Trajectory& gt_sorted, const Trajectory& est,
                                              int64_t offset_ns, int64_t max_gap_ns) {
  std::vector<std::optional<Mat3d>> out(est.size());
  for (size_t i = 0; i < est.size(); ++i) {
    const auto T = InterpolatePose(gt_sorted, est[i].t_ns + offset_ns, max_gap_ns);
    if (T) out[i] = T->linear();
  }
  return out;
}

// The rms angle of R_gt_i vs L * R_est_i over the kept poses, L the chordal mean rotation.
double ResidualRmsDeg(const std::vector<std::optional<Mat3d>>& R_gt, const Trajectory& est,
                      const std::vector<bool>& keep) {
  Mat3d sum = Mat3d::Zero();
  for (size_t i = 0; i < est.size(); ++i) {
    if (keep[i]) sum += *R_gt[i] * est[i].T_world_cam.linear().transpose();
  }
  const Mat3d L = NearestRotation(sum);
  double sum2 = 0;
  size_t n = 0;
  for (size_t i = 0; i < est.size(); ++i) {
    if (!keep[i]) continue;
    const Eigen::AngleAxisd e(R_gt[i]->transpose() * L * est[i].T_world_cam.linear());
    sum2 += e.angle() * e.angle();
    ++n;
  }
  return std::sqrt(sum2 / static_cast<double>(n)) * 180.0 / M_PI;
}

}  // namespace

StatusOr<double> OrientationResidualDeg(const Trajectory& gt_in, const Trajectory& est,
                                        int64_t offset_ns, const ClockOffsetOptions& opt) {
  const Trajectory gt = SortedByTime(gt_in);
  const auto R_gt = GtRotations(gt, est, offset_ns, opt.max_gap_ns);
  std::vector<bool> keep(est.size());
  size_t n = 0;
  for (size_t i = 0; i < est.size(); ++i) n += (keep[i] = R_gt[i].has_value());
  if (n < opt.min_poses) {
    return absl::InvalidArgumentError(absl::StrCat("clock offset: only ", n,
                                                   " estimate poses lie inside the ground truth"));
  }
  return ResidualRmsDeg(R_gt, est, keep);
}

StatusOr<ClockOffset> EstimateClockOffset(const Trajectory& gt_in, const Trajectory& est,
                                          const ClockOffsetOptions& opt) {
  if (opt.step_ns <= 0 || opt.max_offset_ns < 0) {
    return absl::InvalidArgumentError("clock offset: step must be > 0 and the range >= 0");
  }
  const Trajectory gt = SortedByTime(gt_in);
  std::vector<int64_t> offsets;
  for (int64_t o = -opt.max_offset_ns; o <= opt.max_offset_ns; o += opt.step_ns) {
    offsets.push_back(o);
  }
  // One pose set for every offset, so that the residuals compare like with like.
  std::vector<std::vector<std::optional<Mat3d>>> R_gt;
  std::vector<bool> keep(est.size(), true);
  for (const int64_t o : offsets) {
    R_gt.push_back(GtRotations(gt, est, o, opt.max_gap_ns));
    for (size_t i = 0; i < est.size(); ++i) keep[i] = keep[i] && R_gt.back()[i].has_value();
  }
  ClockOffset out;
  out.poses = static_cast<size_t>(std::count(keep.begin(), keep.end(), true));
  if (out.poses < opt.min_poses) {
    return absl::InvalidArgumentError(
        absl::StrCat("clock offset: only ", out.poses,
                     " estimate poses lie inside the ground truth at every offset tried"));
  }
  out.rms_deg = std::numeric_limits<double>::infinity();
  for (size_t k = 0; k < offsets.size(); ++k) {
    const double rms = ResidualRmsDeg(R_gt[k], est, keep);
    if (offsets[k] == 0) out.rms_deg_at_zero = rms;
    if (rms < out.rms_deg) {
      out.rms_deg = rms;
      out.offset_ns = offsets[k];
    }
  }
  return out;
}

}  // namespace loci
