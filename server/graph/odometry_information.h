// Information of an odometry edge from the client's tracking quality (the mapping is documented
// on OdometryInformationOptions in graph_options.h).
#pragma once

#include "server/graph/graph_options.h"
#include "server/graph/graph_types.h"

namespace loci::server {

// Quality in [0, 1]: the client's quality when known, else min(1, inliers /
// full_quality_inliers) when the inlier count is known, else 1.
double EffectiveQuality(const TrackingQuality& quality, const OdometryInformationOptions& options);

// Diagonal information of the odometry measurement T_a_b at that quality.
Information6 OdometryInformation(const SE3d& T_a_b, const TrackingQuality& quality,
                                 const OdometryInformationOptions& options);

}  // namespace loci::server
