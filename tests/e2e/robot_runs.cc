#include "tests/e2e/robot_runs.h"

#include <grpcpp/create_channel.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <thread>

#include "proto/convert.h"
#include "tests/support/server_process.h"

namespace loci::testing {

std::string TrackCommand(const std::string& tum, const std::string& addr, const RobotRun& r) {
  std::string cmd = std::string(LOCI_TRACK_BIN) + " --tum " + tum + " --server " + addr +
                    " --robot " + r.name + " --no-progress --log-level warn " + r.source_args +
                    " --keyframes " + r.keyframes_path + " --start-frame " +
                    std::to_string(r.start_frame);
  if (r.max_frames > 0) cmd += " --max-frames " + std::to_string(r.max_frames);
  if (!r.trajectory_path.empty()) cmd += " --trajectory " + r.trajectory_path;
  return cmd;
}

StatusOr<v1::GetStatsResponse> Stats(v1::Query::Stub& query) {
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
  v1::GetStatsResponse resp;
  const grpc::Status s = query.GetStats(&ctx, v1::GetStatsRequest(), &resp);
  if (!s.ok()) return absl::UnavailableError(s.error_message());
  return resp;
}

PoseError Error(const SE3d& truth, const SE3d& estimate) {
  const SE3d d = truth.inverse() * estimate;
  return {d.translation().norm(), Eigen::AngleAxisd(d.linear()).angle() * 180.0 / M_PI};
}

namespace {

// Whether the server has mapped every keyframe of its aligned sessions.
bool CaughtUp(const v1::GetStatsResponse& s) {
  uint64_t aligned_keyframes = 0;
  for (const v1::SessionAlignment& a : s.session_alignments()) {
    if (a.aligned()) aligned_keyframes += a.keyframes();
  }
  return s.queue_depth() == 0 && s.mapped_keyframes() >= aligned_keyframes;
}

// Polls GetStats (with a deadline) until `done` holds; the last response. Only for what the
// server reports as counters alone: a loci-server process says when its mapping queue has
// drained in no other way (no event, output line or blocking call).
StatusOr<v1::GetStatsResponse> StatsWhen(v1::Query::Stub& query,
                                         bool (*done)(const v1::GetStatsResponse&)) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  StatusOr<v1::GetStatsResponse> s = Stats(query);
  while (s.ok() && !done(*s) && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));  // poll
    s = Stats(query);
  }
  return s;
}

// Blocks until the server sends its first object event (a keyframe of the map was mapped) or
// the watch ends: cancelled when the first robot ended without one, or at its deadline.
void FirstObjectEvent(grpc::ClientReader<v1::ObjectEvent>& events, grpc::ClientContext& watch) {
  v1::ObjectEvent event;
  events.Read(&event);
  watch.TryCancel();
  events.Finish();
}

std::map<std::string, Trajectory> MappedTrajectories(v1::Query::Stub& query) {
  std::map<std::string, Trajectory> out;
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
  v1::GetTrajectoriesResponse resp;
  EXPECT_TRUE(query.GetTrajectories(&ctx, v1::GetTrajectoriesRequest(), &resp).ok());
  for (const v1::Trajectory& t : resp.trajectories()) {
    for (const v1::StampedPose& p : t.poses()) {
      out[t.robot()].push_back({p.t_ns(), PoseFromProto(p.t_map_cam())});
    }
  }
  return out;
}

}  // namespace

RobotsResult RunRobots(const std::string& tum, const std::vector<RobotRun>& robots,
                       const std::string& dir, const std::string& config) {
  RobotsResult out;
  ServerProcess server(ServerProcessOptions{
      .db = dir + "/loci.db",
      .config = config.empty() ? std::string(LOCI_SOURCE_DIR) + "/config/server.yaml" : config,
      .stderr_path = dir + "/server.log"});
  EXPECT_GT(server.port(), 0) << "loci-server did not print its port";
  if (server.port() == 0) return out;
  auto query = v1::Query::NewStub(
      grpc::CreateChannel(server.address(), grpc::InsecureChannelCredentials()));
  // Watching before the first robot starts: its first mapped keyframe that sees an object is
  // the event the others wait for, and its end when it has none.
  grpc::ClientContext watch;
  watch.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(120));
  auto events = query->WatchObjects(&watch, v1::WatchObjectsRequest());
  events->WaitForInitialMetadata();  // sent once the watch is registered
  std::vector<int> rc(robots.size(), -1);
  std::vector<std::thread> threads;
  auto start = [&](size_t i) {
    threads.emplace_back([&, i] {
      rc[i] = std::system(TrackCommand(tum, server.address(), robots[i]).c_str());
      if (i == 0) watch.TryCancel();
    });
  };
  start(0);
  FirstObjectEvent(*events, watch);
  const auto first = Stats(*query);
  EXPECT_TRUE(first.ok() && first->keyframes() > 0)
      << robots[0].name << " stored no keyframe within 120 s";
  for (size_t i = 1; i < robots.size(); ++i) start(i);
  for (std::thread& t : threads) t.join();
  for (size_t i = 0; i < robots.size(); ++i) EXPECT_EQ(rc[i], 0) << robots[i].name;
  auto stats = StatsWhen(*query, CaughtUp);
  EXPECT_TRUE(stats.ok());
  if (stats.ok()) out.stats = *stats;
  grpc::ClientContext ctx;
  v1::FindObjectsRequest find;
  find.set_confirmed_only(true);
  v1::FindObjectsResponse found;
  EXPECT_TRUE(query->FindObjects(&ctx, find, &found).ok());
  out.objects.assign(found.objects().begin(), found.objects().end());
  out.mapped = MappedTrajectories(*query);
  for (const RobotRun& r : robots) {
    auto k = ReadTumTrajectory(r.keyframes_path);
    if (k.ok()) out.keyframes[r.name] = *k;
  }
  for (const RobotRun& r : robots) {
    auto f = ReadTumTrajectory(r.trajectory_path);
    if (!r.trajectory_path.empty() && f.ok()) out.frames[r.name] = *f;
  }
  return out;
}

}  // namespace loci::testing
