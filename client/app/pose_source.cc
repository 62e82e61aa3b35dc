#include "client/app/pose_source.h"

#include <algorithm>

#include "common/time.h"

namespace loci {

StatusOr<std::unique_ptr<PoseSource>> PoseSource::FromFile(const std::string& path,
                                                           const KeyframeRuleOptions& rules,
                                                           int64_t max_dt_ns) {
  LOCI_ASSIGN_OR_RETURN(Trajectory traj, ReadTumTrajectory(path));
  if (traj.empty()) return absl::InvalidArgumentError(absl::StrCat(path, ": no poses"));
  std::sort(traj.begin(), traj.end(),
            [](const StampedPose& a, const StampedPose& b) { return a.t_ns < b.t_ns; });
  auto p = std::unique_ptr<PoseSource>(new PoseSource());
  p->poses_ = std::move(traj);
  p->rules_ = rules;
  p->max_dt_ns_ = max_dt_ns;
  return p;
}

StatusOr<FrameResult> PoseSource::At(int64_t t_ns) {
  FrameResult r;
  r.t_ns = t_ns;
  const StampedPose* best = NearestByTime<StampedPose>(poses_, t_ns, max_dt_ns_);
  if (!best) {
    r.state = TrackState::kLost;
    return r;
  }
  r.tracked = true;
  r.state = TrackState::kTracking;
  r.T_odom_cam = best->T_world_cam;
  ++frames_since_kf_;
  const SE3d T_kf_cur = T_odom_lastkf_.inverse() * r.T_odom_cam;
  if (!have_kf_ || frames_since_kf_ >= rules_.max_frames_between ||
      RotationAngleRad(T_kf_cur) > rules_.min_rotation_rad ||
      T_kf_cur.translation().norm() > rules_.min_translation_m) {
    r.keyframe = true;
    have_kf_ = true;
    T_odom_lastkf_ = r.T_odom_cam;
    frames_since_kf_ = 0;
  }
  return r;
}

}  // namespace loci
