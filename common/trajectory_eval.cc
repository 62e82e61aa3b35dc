#include "common/trajectory_eval.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <Eigen/Geometry>

#include "common/time.h"

namespace loci {

ErrorStats ComputeErrorStats(std::vector<double> e) {
  ErrorStats s;
  s.count = e.size();
  if (e.empty()) return s;
  double sum = 0, sum2 = 0;
  for (double x : e) {
    sum += x;
    sum2 += x * x;
  }
  s.mean = sum / e.size();
  s.rmse = std::sqrt(sum2 / e.size());
  s.std = std::sqrt(std::max(0.0, sum2 / e.size() - s.mean * s.mean));
  std::sort(e.begin(), e.end());
  s.min = e.front();
  s.max = e.back();
  // numpy.median: mean of the two middle values for even counts.
  const size_t n = e.size();
  s.median = n % 2 ? e[n / 2] : 0.5 * (e[n / 2 - 1] + e[n / 2]);
  return s;
}

namespace {

std::vector<int64_t> Stamps(const Trajectory& t) {
  std::vector<int64_t> s;
  s.reserve(t.size());
  for (const auto& p : t) s.push_back(p.t_ns);
  return s;
}

// Index of the stamp closest to t in a sorted vector.
size_t ClosestIndex(const std::vector<int64_t>& sorted, int64_t t) {
  auto it = std::lower_bound(sorted.begin(), sorted.end(), t);
  if (it == sorted.begin()) return 0;
  if (it == sorted.end()) return sorted.size() - 1;
  const size_t hi = it - sorted.begin();
  return (t - sorted[hi - 1] <= sorted[hi] - t) ? hi - 1 : hi;
}

// Index pairs (gt, est) of sorted trajectories whose stamps (est shifted by offset_ns) lie within
// max_dt_ns, as the TUM associate.py pairs them.
std::vector<std::pair<size_t, size_t>> Associate(const Trajectory& gt, const Trajectory& est,
                                                 const AteOptions& opt) {
  std::vector<int64_t> te = Stamps(est);
  for (auto& t : te) t += opt.offset_ns;
  return AssociateStamps(Stamps(gt), te, opt.max_dt_ns);
}

}  // namespace

Trajectory SortedByTime(Trajectory t) {
  std::sort(t.begin(), t.end(),
            [](const StampedPose& a, const StampedPose& b) { return a.t_ns < b.t_ns; });
  return t;
}

Mat3d NearestRotation(const Mat3d& m) {
  const Eigen::JacobiSVD<Mat3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3d d = Mat3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  return svd.matrixU() * d * svd.matrixV().transpose();
}

StatusOr<AteResult> ComputeAte(const Trajectory& gt_in, const Trajectory& est_in,
                               const AteOptions& opt) {
  const Trajectory gt = SortedByTime(gt_in), est = SortedByTime(est_in);
  const auto pairs = Associate(gt, est, opt);
  if (pairs.size() < 3) {
    return absl::InvalidArgumentError(absl::StrCat(
        "ATE: only ", pairs.size(),
        " stamp pairs within the association window; are these the right files?"));
  }
  Eigen::Matrix3Xd src(3, pairs.size()), dst(3, pairs.size());
  for (size_t k = 0; k < pairs.size(); ++k) {
    dst.col(k) = gt[pairs[k].first].T_world_cam.translation();
    src.col(k) = est[pairs[k].second].T_world_cam.translation();
  }
  // Horn's closed form == Umeyama without scale.
  const Eigen::Matrix4d T = Eigen::umeyama(src, dst, false);
  AteResult r;
  r.T_gt_est.matrix() = T;
  r.pairs = pairs.size();
  std::vector<double> err(pairs.size());
  for (size_t k = 0; k < pairs.size(); ++k) err[k] = (r.T_gt_est * src.col(k) - dst.col(k)).norm();
  r.trans_m = ComputeErrorStats(std::move(err));
  return r;
}

namespace {

// The chordal mean of R_gt_i * R_est_i^T over associated pairs of sorted trajectories.
Mat3d ChordalMeanRotation(const Trajectory& gt, const Trajectory& est,
                          const std::vector<std::pair<size_t, size_t>>& pairs) {
  Mat3d sum = Mat3d::Zero();
  for (const auto& [g, e] : pairs) {
    sum += gt[g].T_world_cam.linear() * est[e].T_world_cam.linear().transpose();
  }
  return NearestRotation(sum);
}

}  // namespace

StatusOr<Mat3d> OrientationAlignment(const Trajectory& gt_in, const Trajectory& est_in,
                                     const AteOptions& opt) {
  const Trajectory gt = SortedByTime(gt_in), est = SortedByTime(est_in);
  const auto pairs = Associate(gt, est, opt);
  if (pairs.empty()) return absl::InvalidArgumentError("no stamp pairs within the window");
  return ChordalMeanRotation(gt, est, pairs);
}

StatusOr<SE3d> AlignByOrientations(const Trajectory& gt_in, const Trajectory& est_in,
                                   const AteOptions& opt) {
  const Trajectory gt = SortedByTime(gt_in), est = SortedByTime(est_in);
  const auto pairs = Associate(gt, est, opt);
  if (pairs.empty()) return absl::InvalidArgumentError("no stamp pairs within the window");
  Vec3d gt_sum = Vec3d::Zero(), est_sum = Vec3d::Zero();
  for (const auto& [g, e] : pairs) {
    gt_sum += gt[g].T_world_cam.translation();
    est_sum += est[e].T_world_cam.translation();
  }
  const double n = static_cast<double>(pairs.size());
  SE3d T_gt_est = SE3d::Identity();
  T_gt_est.linear() = ChordalMeanRotation(gt, est, pairs);
  T_gt_est.translation() = gt_sum / n - T_gt_est.linear() * (est_sum / n);
  return T_gt_est;
}

StatusOr<RpeResult> ComputeRpe(const Trajectory& gt_in, const Trajectory& est_in,
                               const RpeOptions& opt) {
  const Trajectory gt = SortedByTime(gt_in), est = SortedByTime(est_in);
  if (gt.size() < 2 || est.size() < 2) {
    return absl::InvalidArgumentError("RPE: need at least two poses in each trajectory");
  }
  const std::vector<int64_t> tg = Stamps(gt), te = Stamps(est);
  std::vector<int64_t> intervals;
  for (size_t k = 1; k < tg.size(); ++k) intervals.push_back(tg[k] - tg[k - 1]);
  std::nth_element(intervals.begin(), intervals.begin() + intervals.size() / 2, intervals.end());
  const int64_t gt_max_dt = 2 * intervals[intervals.size() / 2];
  const int64_t delta_ns = SecondsToNs(opt.delta_s);

  std::vector<double> et, er;
  for (size_t i = 0; i < te.size(); ++i) {
    const size_t j = ClosestIndex(te, te[i] + delta_ns);
    if (j == te.size() - 1) continue;  // evaluate_rpe.py drops pairs ending at the last pose
    const size_t gi = ClosestIndex(tg, te[i] + opt.offset_ns);
    const size_t gj = ClosestIndex(tg, te[j] + opt.offset_ns);
    if (std::llabs(tg[gi] - (te[i] + opt.offset_ns)) > gt_max_dt ||
        std::llabs(tg[gj] - (te[j] + opt.offset_ns)) > gt_max_dt) {
      continue;
    }
    const SE3d d_est = est[i].T_world_cam.inverse() * est[j].T_world_cam;
    const SE3d d_gt = gt[gi].T_world_cam.inverse() * gt[gj].T_world_cam;
    const SE3d e = d_est.inverse() * d_gt;
    et.push_back(e.translation().norm());
    er.push_back(RotationAngleRad(e));
  }
  if (et.empty()) return absl::InvalidArgumentError("RPE: no pose pairs overlap ground truth");
  RpeResult r;
  r.delta_s = opt.delta_s;
  r.pairs = et.size();
  r.trans_m = ComputeErrorStats(std::move(et));
  r.rot_rad = ComputeErrorStats(std::move(er));
  return r;
}

}  // namespace loci
