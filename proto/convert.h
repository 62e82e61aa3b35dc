// Conversions from the common C++ types to protocol v1 messages, written once for the client,
// the benchmarks and the tests. (The server's validating decoders live in server/service.)
#pragma once

#include <Eigen/Core>

#include "common/camera.h"
#include "common/detections_io.h"
#include "common/se3.h"
#include "common/status.h"
#include "loci/v1/types.pb.h"

namespace loci {

// T_a_b as translation (m) + unit quaternion with w >= 0.
void ToProto(const SE3d& T_a_b, v1::Pose* out);
void ToProto(const Eigen::Vector3d& v, v1::Vec3* out);
void ToProto(const PinholeCamera& camera, v1::CameraIntrinsics* out);
// The inverse of ToProto(SE3d) (the quaternion is normalised; no validation).
SE3d PoseFromProto(const v1::Pose& p);
// A detection with its optional mask encoded as an 8-bit PNG.
Status ToProto(const Detection2D& d, v1::Detection* out);

}  // namespace loci
