// Test-side gRPC streaming of prepared keyframes to a server (in-process or a child process).
#pragma once

#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include "loci/v1/mapping.grpc.pb.h"
#include "loci/v1/query.grpc.pb.h"
#include "common/map_object.h"
#include "tests/support/server_process.h"

namespace loci::server::testing {

// Opens (or resumes) a session of `robot` on TUM fr1 intrinsics, naming `site` when not empty;
// fails the test on an error. *last gets the last stored seq.
std::string OpenSessionOn(loci::v1::Mapping::Stub* stub, const std::string& robot, bool resume,
                          int64_t* last = nullptr, const std::string& site = "");

// Streams keyframes [begin, end) of `keyframes` on one stream, waiting for each ack.
std::vector<loci::v1::KeyframeAck> StreamAcked(loci::v1::Mapping::Stub* stub,
                                               const std::string& session,
                                               const std::vector<loci::v1::Keyframe>& keyframes,
                                               int begin, int end);

// Writes keyframes [begin, end) without waiting for acks and SIGKILLs `server` after writing
// keyframe kill_at; acknowledged seqs go to *acked.
void StreamAndKill(loci::v1::Mapping::Stub* stub, const std::string& session,
                   const std::vector<loci::v1::Keyframe>& keyframes, int begin, int end,
                   int kill_at, loci::testing::ServerProcess* server, std::set<int64_t>* acked);

// The server's confirmed objects (FindObjects).
std::vector<MapObject> ConfirmedObjects(loci::v1::Query::Stub* stub);

}  // namespace loci::server::testing
