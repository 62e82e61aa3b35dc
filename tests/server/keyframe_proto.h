// Builds protocol v1 messages for server tests (the test-side streamer; loci-track streams with
// client/streaming/map_client.h).
#pragma once

#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/camera.h"
#include "common/detections_io.h"
#include "common/se3.h"
#include "loci/v1/mapping.pb.h"

namespace loci::server::testing {

loci::v1::OpenSessionRequest OpenRequest(const std::string& robot, const PinholeCamera& camera,
                                         bool resume = false);

// A keyframe with JPEG colour and 16-bit PNG depth (5000 per metre), detections with masks.
loci::v1::Keyframe MakeKeyframe(const std::string& session_id, int64_t seq, int64_t t_ns,
                                const SE3d& T_odom_cam, const cv::Mat& bgr,
                                const cv::Mat& depth_u16,
                                const std::vector<Detection2D>& detections,
                                std::optional<Eigen::Vector3d> gravity_cam = std::nullopt);

// Same from already encoded images (TUM / synth folders).
loci::v1::Keyframe MakeKeyframeFromBytes(const std::string& session_id, int64_t seq, int64_t t_ns,
                                         const SE3d& T_odom_cam, std::string rgb_jpeg,
                                         std::string depth_png,
                                         const std::vector<Detection2D>& detections,
                                         std::optional<Eigen::Vector3d> gravity_cam);

}  // namespace loci::server::testing
