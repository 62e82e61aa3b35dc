// Load generators of the `loci bench` commands that drive a server over loopback gRPC: robots
// streaming rendered views, query clients calling Ask and FindObjects.
#pragma once

#include <grpcpp/channel.h>

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "loci/v1/mapping.pb.h"

namespace loci::cli {

struct Latencies {
  std::mutex mu;
  std::vector<double> ask_ms, find_ms;  // guarded by mu
  std::atomic<uint64_t> errors{0};
};

// One robot: a session named `robot` (of `site` when not empty) and one stream of `views`
// cycled with fresh seqs, paced at robot_hz (0: as fast as acknowledged), until `stop`.
void RobotLoop(const std::shared_ptr<grpc::Channel>& channel, const std::string& robot,
               const std::string& site, const std::vector<loci::v1::Keyframe>& views,
               double robot_hz, const std::atomic<bool>& stop, std::atomic<uint64_t>* acked,
               std::atomic<uint64_t>* errors);

// One query client: Ask and FindObjects in turn (client_hz calls per second, 0: unpaced) until
// `stop`; `find_only`: FindObjects only.
void ClientLoop(const std::shared_ptr<grpc::Channel>& channel, double client_hz, bool find_only,
                const std::atomic<bool>& stop, Latencies* out);

}  // namespace loci::cli
