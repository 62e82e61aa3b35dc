// loci::MapClient: streams keyframes to loci-server (proto loci.v1.Mapping) with a bounded send
// window and automatic resume.
//
//   auto client = MapClient::Connect(options, camera, depth_scale);   // OpenSession
//   (*client)->Send(keyframe);      // blocks while `max_unacked` keyframes await their ack
//   (*client)->Close();             // waits for every ack, then CloseSession
//
// Every keyframe stays in memory until the server acknowledges it (after its commit). When the
// stream breaks (server restart, network), a background thread reconnects with exponential
// back-off, reopens the session with resume=true (last_stored_seq tells what is already stored)
// and resends every unacknowledged keyframe in order; the server de-duplicates by seq. Nothing
// is ever dropped silently: Send blocks (back-pressure) and Close reports what was not stored.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "common/camera.h"
#include "common/detections_io.h"
#include "common/se3.h"
#include "common/status.h"
#include "proto/channel.h"

namespace loci {

struct MapClientOptions {
  std::string server = "127.0.0.1:50051";  // HOST:PORT of loci-server
  std::string robot_name = "robot";        // [A-Za-z0-9_.-]{1,64}
  std::string site;                        // the site the robot maps; "" = the server's
  int max_unacked = 16;                    // keyframes sent or queued without ack (back-pressure)
  double initial_backoff_s = 0.1;          // first reconnect delay, doubled up to max_backoff_s
  double max_backoff_s = 2.0;
  double rpc_timeout_s = 5.0;  // deadline of OpenSession / CloseSession
  // Connect waits this long for a server that is not up yet (starting), logging progress.
  double connect_timeout_s = 30.0;
  ChannelSecurity security;  // bearer token and TLS (proto/channel.h)
  int jpeg_quality = 90;       // RGB JPEG quality [1, 100]
  std::string client_version = "loci-track 0.1.0";
};

// One keyframe as the tracker produces it; MapClient encodes it (JPEG + 16-bit PNG).
struct KeyframeData {
  int64_t t_ns = 0;
  SE3d T_odom_cam = SE3d::Identity();
  cv::Mat bgr;        // CV_8UC3
  cv::Mat depth_u16;  // CV_16UC1, depth_scale units per metre
  std::vector<Detection2D> detections;
  std::optional<Vec3d> gravity_cam;  // unit, pointing down, cam frame
  int segment = 0;
  int tracking_inliers = 0;  // inliers of the pose estimate (tracking quality); 0 = unknown
};

struct MapClientStats {
  int64_t queued = 0;      // keyframes handed to Send
  int64_t acked = 0;       // acknowledged as stored (including duplicates)
  int64_t duplicates = 0;  // acknowledged as already stored (after a resend)
  int64_t rejected = 0;    // acknowledged with an error status
  int64_t reconnects = 0;  // streams re-opened after a failure
  int64_t bytes_sent = 0;  // encoded keyframe bytes written (resends included)
  std::string last_error;
};

class MapClient {
 public:
  static StatusOr<std::unique_ptr<MapClient>> Connect(const MapClientOptions& options,
                                                      const PinholeCamera& camera,
                                                      double depth_scale);
  ~MapClient();
  MapClient(const MapClient&) = delete;
  MapClient& operator=(const MapClient&) = delete;

  // Queues a keyframe (seq = 0, 1, 2... in call order, continuing after a resume) and returns
  // its seq. Blocks while max_unacked keyframes are waiting; Unavailable after Close.
  StatusOr<int64_t> Send(KeyframeData keyframe);
  // Waits up to timeout_s for every ack, ends the stream and closes the session. At the
  // deadline the stream is cancelled, even mid-Write, so Close returns within timeout_s (plus
  // the cancellation): DeadlineExceeded with the count of keyframes not acknowledged, and the
  // session left open for a later resume.
  Status Close(double timeout_s = 60.0);

  MapClientStats stats() const;
  std::string session_id() const;
  int64_t unacked() const;

 private:
  struct Impl;
  explicit MapClient(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace loci
