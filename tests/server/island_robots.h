// Robots streaming `loci synth` rooms to an in-process loci-server on loopback gRPC, for the
// map-island tests (islands_test.cc, island_loops_test.cc).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "loci/v1/mapping.grpc.pb.h"
#include "loci/v1/query.grpc.pb.h"
#include "server/service/grpc_server.h"
#include "server/runtime/map_server.h"
#include "server/runtime/server_options.h"
#include "synth/scene.h"

namespace loci::server::testing {

// A room of 45 frames at 5 Hz with 8 objects (`num_frames` to change it).
synth::SceneOptions Room(uint64_t seed, int num_frames = 45);

// A running server with its gRPC endpoint and stubs.
struct Running {
  std::unique_ptr<MapServer> server;
  std::unique_ptr<GrpcServer> grpc;
  std::unique_ptr<loci::v1::Mapping::Stub> mapping;
  std::unique_ptr<loci::v1::Query::Stub> query;
};

// The server's defaults, with depth read to 6 m as in the integration test (the synth rooms'
// shelves stand about 4 m from the camera).
ServerOptions Options();

// `loops`: align.loops.enabled (loop closure of the shared map and of each island).
Running Start(const std::string& db, bool loops = true);
// With these options (their db_path is set to `db`).
Running Start(const std::string& db, ServerOptions options);

// Views [first, end) as a robot sends them: with `own_odometry` the poses are re-based on view
// `first` (the robot's odometry starts at the identity there), else the scene's.
std::vector<loci::v1::Keyframe> Rebased(const std::vector<loci::v1::Keyframe>& views, size_t first,
                                        bool own_odometry);

// Streams the keyframes as robot `robot` (seq = their index), waiting for each ack. Returns the
// session id.
std::string Stream(loci::v1::Mapping::Stub* stub, const std::string& robot,
                   const std::vector<loci::v1::Keyframe>& keyframes);
// Streams more keyframes into an open session, seq numbers from first_seq.
void StreamInto(loci::v1::Mapping::Stub* stub, const std::string& session_id,
                const std::vector<loci::v1::Keyframe>& keyframes, int64_t first_seq);

loci::v1::GetStatsResponse Stats(loci::v1::Query::Stub* stub);

// Every session of the stats, by robot name.
std::map<std::string, loci::v1::SessionAlignment> SessionsByRobot(
    const loci::v1::GetStatsResponse& stats);

}  // namespace loci::server::testing
