// The offset between an estimate's image stamps and a ground truth's clock, found from the
// trajectories themselves (temporal calibration, as Kalibr estimates a camera-IMU delay).
//
// TUM RGB-D stamps each image when the host received it, after exposure, readout and USB
// transfer, while the motion capture stamps its own samples. On a camera that turns fast (fr1_rpy
// turns at up to 125 deg/s, 1.6 deg per 13 ms) the ground truth at the image stamp is then not the
// pose the image was taken at, and orientation errors measured there include that delay.
#pragma once

#include <cstdint>

#include "common/status.h"
#include "common/tum_io.h"

namespace loci {

struct ClockOffsetOptions {
  int64_t max_offset_ns = 60'000'000;  // searched over [-max, +max]
  int64_t step_ns = 1'000'000;
  int64_t max_gap_ns = 40'000'000;     // ground truth interpolated across gaps up to this
  size_t min_poses = 20;
};

struct ClockOffset {
  int64_t offset_ns = 0;       // add to the estimate's stamps to read the ground truth
  double rms_deg_at_zero = 0;  // orientation residual (rms) at the stamps as given
  double rms_deg = 0;          // at offset_ns
  size_t poses = 0;            // estimate poses inside the ground truth at every offset tried
};

// The orientation residual (rms, degrees) of `est` against `gt` interpolated (slerp) at each
// stamp + offset_ns, after the best constant rotation between the two frames (the chordal mean
// of R_gt * R_est^T). Poses whose shifted stamp falls outside `gt` are left out; fewer than
// opt.min_poses left is an error.
StatusOr<double> OrientationResidualDeg(const Trajectory& gt, const Trajectory& est,
                                        int64_t offset_ns, const ClockOffsetOptions& opt = {});

// The offset in [-max, +max] (steps of opt.step_ns) that minimises OrientationResidualDeg.
// Only orientations are used: they do not depend on the scale or the frame of the translation,
// and a turning camera constrains the offset through them most. `est` must move: a still camera
// gives no offset (the residual is flat), and the result then says so by rms_deg ~ rms_deg_at_zero.
StatusOr<ClockOffset> EstimateClockOffset(const Trajectory& gt, const Trajectory& est,
                                          const ClockOffsetOptions& opt = {});

}  // namespace loci
