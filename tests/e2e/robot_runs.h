// Robots streaming to a real loci-server on loopback, for the many-robot and loop-closure
// end-to-end tests: one loci-track process per robot on a TUM folder (the first started alone,
// the others once the server mapped its first keyframe), then the server's figures.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "common/se3.h"
#include "common/status.h"
#include "common/tum_io.h"
#include "loci/v1/query.grpc.pb.h"

namespace loci::testing {

struct RobotRun {
  std::string name;
  int start_frame = 0;
  int max_frames = 0;  // 0 = to the end
  std::string keyframes_path;
  std::string trajectory_path;  // every frame's pose; "" = not written
  std::string source_args = "--model " + std::string(LOCI_SOURCE_DIR) + "/models/yolox_nano/yolox_nano.onnx";
};

std::string TrackCommand(const std::string& tum, const std::string& addr, const RobotRun& r);
StatusOr<v1::GetStatsResponse> Stats(v1::Query::Stub& query);

struct PoseError {
  double t_m = 0, r_deg = 0;
};
PoseError Error(const SE3d& truth, const SE3d& estimate);

struct RobotsResult {
  v1::GetStatsResponse stats;
  std::vector<v1::Object> objects;              // confirmed
  std::map<std::string, Trajectory> keyframes;  // by robot, as each client wrote them
  std::map<std::string, Trajectory> frames;     // every frame's pose, robots with a trajectory_path
  std::map<std::string, Trajectory> mapped;     // the server's keyframe poses (map frame), by robot
};

// Starts the first robot, then, once the server has mapped its first keyframe (so its session
// is the map's origin; the first object event says so, or the first robot's end when it sees
// none), all the others; they stream at once. The figures are read once the server has mapped
// every keyframe it stored (with every session aligned) or 120 s passed.
// `config`: the server's YAML ("" = config/server.yaml).
RobotsResult RunRobots(const std::string& tum, const std::vector<RobotRun>& robots,
                       const std::string& dir, const std::string& config = "");

}  // namespace loci::testing
