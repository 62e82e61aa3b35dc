#include "server/graph/odometry_information.h"

#include <algorithm>

namespace loci::server {

double EffectiveQuality(const TrackingQuality& q, const OdometryInformationOptions& o) {
  if (q.quality >= 0) return std::min(1.0, q.quality);
  if (q.inliers >= 0) return std::min(1.0, static_cast<double>(q.inliers) / o.full_quality_inliers);
  return 1.0;
}

Information6 OdometryInformation(const SE3d& T_a_b, const TrackingQuality& quality,
                                 const OdometryInformationOptions& o) {
  const double scale = std::max(EffectiveQuality(quality, o), o.min_quality);
  const double sigma_t = (o.sigma_trans_m + o.sigma_trans_per_m * T_a_b.translation().norm()) /
                         scale;
  const double sigma_r = (o.sigma_rot_rad + o.sigma_rot_per_rad * RotationAngleRad(T_a_b)) / scale;
  return IsotropicInformation(sigma_t, sigma_r);
}

}  // namespace loci::server
