// Trajectory metrics exactly as the TUM RGB-D benchmark tools compute them
// (evaluate_ate.py, evaluate_rpe.py --fixed_delta --delta 1 --delta_unit s).
#pragma once

#include <cstdint>
#include <vector>

#include "common/status.h"
#include "common/tum_io.h"

namespace loci {

struct ErrorStats {
  size_t count = 0;
  double rmse = 0, mean = 0, median = 0, std = 0, min = 0, max = 0;
};
ErrorStats ComputeErrorStats(std::vector<double> errors);

struct AteResult {
  ErrorStats trans_m;   // translational error after alignment, metres
  SE3d T_gt_est;        // the rigid alignment applied to the estimate
  size_t pairs = 0;
};

struct AteOptions {
  int64_t max_dt_ns = 20'000'000;  // associate.py --max_difference 0.02
  int64_t offset_ns = 0;           // added to the estimate's stamps
};

// Associates stamps, aligns the estimate to ground truth with Horn/Umeyama (rotation +
// translation, no scale) and returns the translational error statistics.
StatusOr<AteResult> ComputeAte(const Trajectory& gt, const Trajectory& est,
                               const AteOptions& opt = {});

// The rotation nearest m in the Frobenius norm: U diag(1, 1, det(U V^T)) V^T of m's SVD (the
// chordal mean of rotations when m is their sum).
Mat3d NearestRotation(const Mat3d& m);

// The poses ordered by stamp.
Trajectory SortedByTime(Trajectory t);

// The rotation that best carries the estimate's camera orientations onto the ground truth's:
// the chordal mean of R_gt_i * R_est_i^T over the stamps ComputeAte associates. A check on
// ComputeAte's alignment, which uses positions only and so is ill-conditioned in rotation when
// the camera barely translates (fr1_rpy: its keyframes lie within about 7 cm of their mean).
StatusOr<Mat3d> OrientationAlignment(const Trajectory& gt, const Trajectory& est,
                                     const AteOptions& opt = {});

// A rigid alignment from the whole poses: the rotation of OrientationAlignment, then the
// translation that best carries the estimate's positions onto the ground truth's under it
// (the difference of the means). For sequences that turn in place (fr1_rpy), where ComputeAte's
// rotation is set by centimetre noise over a few centimetres of travel.
StatusOr<SE3d> AlignByOrientations(const Trajectory& gt, const Trajectory& est,
                                   const AteOptions& opt = {});

struct RpeResult {
  ErrorStats trans_m;     // per delta: m over delta_s (delta 1 s: m/s)
  ErrorStats rot_rad;     // per delta: rad over delta_s
  double delta_s = 1.0;
  size_t pairs = 0;
};

struct RpeOptions {
  double delta_s = 1.0;   // window; the benchmark's --delta 1 --delta_unit s
  int64_t offset_ns = 0;
};

// Relative pose error over fixed time windows: for each estimated pose i, j is the estimated
// pose closest to t_i + delta; the error is (est_i^-1 est_j)^-1 (gt_i^-1 gt_j) with gt poses
// nearest in time (within twice the median gt interval).
StatusOr<RpeResult> ComputeRpe(const Trajectory& gt, const Trajectory& est,
                               const RpeOptions& opt = {});

}  // namespace loci
