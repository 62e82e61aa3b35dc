// An island's own loop closure (issue 15), on loopback gRPC: robot A maps one `loci synth`
// room (the shared map); robot B, whose odometry drifts (a steady yaw and translation drift,
// as a visual odometry's), swings its camera back and forth in another room for 30 s. B is never
// aligned, so its keyframes are mapped in an island of its own; the island's pose graph must
// close B's loops there: the keyframe ATE of the island's trajectory (GetTrajectories with the
// island) is at most a third of the drifted one B sent. A restart maps the island again from
// the odometry and solves its graph once more, to the same figure.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "common/trajectory_eval.h"
#include "proto/convert.h"
#include "server/service/proto_convert.h"
#include "synth/sequence_writer.h"
#include "tests/server/island_robots.h"
#include "tests/server/scene_stream.h"

namespace loci::server {
namespace {

namespace fs = std::filesystem;
using testing::Rebased;
using testing::Room;
using testing::Running;
using testing::SessionsByRobot;
using testing::Start;
using testing::Stats;
using testing::Stream;

// The views' poses drifted: the odometry frame turns about the world's up axis by
// yaw_deg_per_s and slides by v_m_per_s, so roll and pitch stay true (B's gravity agrees).
std::vector<loci::v1::Keyframe> Drifted(std::vector<loci::v1::Keyframe> views,
                                        double yaw_deg_per_s, const Vec3d& v_m_per_s) {
  const int64_t t0_ns = views.front().t_ns();
  for (loci::v1::Keyframe& kf : views) {
    const double t_s = 1e-9 * static_cast<double>(kf.t_ns() - t0_ns);
    SE3d D = SE3d::Identity();
    D.linear() =
        Eigen::AngleAxisd(yaw_deg_per_s * t_s * M_PI / 180, Vec3d::UnitZ()).toRotationMatrix();
    D.translation() = v_m_per_s * t_s;
    ToProto(D * PoseFromProto(kf.t_odom_cam()), kf.mutable_t_odom_cam());
  }
  return views;
}

Trajectory Poses(const std::vector<loci::v1::Keyframe>& views) {
  Trajectory out;
  for (const loci::v1::Keyframe& kf : views) {
    out.push_back({kf.t_ns(), PoseFromProto(kf.t_odom_cam())});
  }
  return out;
}

// The island's keyframe poses (its own frame) for robot `robot`.
Trajectory IslandTrajectory(loci::v1::Query::Stub* stub, const std::string& island,
                            const std::string& robot) {
  grpc::ClientContext ctx;
  loci::v1::GetTrajectoriesRequest req;
  req.set_island(island);
  loci::v1::GetTrajectoriesResponse resp;
  const grpc::Status st = stub->GetTrajectories(&ctx, req, &resp);
  EXPECT_TRUE(st.ok()) << st.error_message();
  Trajectory out;
  for (const loci::v1::Trajectory& t : resp.trajectories()) {
    if (t.robot() != robot) continue;
    for (const loci::v1::StampedPose& p : t.poses()) {
      out.push_back({p.t_ns(), PoseFromProto(p.t_map_cam())});
    }
  }
  return out;
}

double Ate(const Trajectory& truth, const Trajectory& estimate) {
  auto ate = ComputeAte(truth, estimate);
  EXPECT_TRUE(ate.ok()) << ate.status();
  return ate.ok() ? ate->trans_m.rmse : 1e9;
}

// B's session in the stats once its island's graph was solved at least `solves` times, polled
// (GetStats, a real signal) for at most 60 s; the last one seen otherwise.
loci::v1::SessionAlignment IslandSolved(loci::v1::Query::Stub* stub, uint64_t solves) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  loci::v1::SessionAlignment b = SessionsByRobot(Stats(stub))["B"];
  while (b.island_optimizations() < solves && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));  // poll
    b = SessionsByRobot(Stats(stub))["B"];
  }
  return b;
}

TEST(IslandLoops, AnUnalignedRobotsDriftIsCutToAThirdInItsIsland) {
  const std::string dir = ::testing::TempDir() + "/loci_island_loops_" + std::to_string(getpid());
  fs::remove_all(dir);
  fs::create_directories(dir);
  ASSERT_TRUE(synth::WriteSequence(Room(2), dir + "/a").ok());
  ASSERT_TRUE(synth::WriteSequence(Room(1, 150), dir + "/b").ok());
  auto a = testing::LoadSceneKeyframes(dir + "/a");
  auto b = testing::LoadSceneKeyframes(dir + "/b");
  ASSERT_TRUE(a.ok() && b.ok());
  const std::vector<loci::v1::Keyframe> b_sent =
      Rebased(Drifted(*b, 0.5, Vec3d(0.006, -0.005, 0)), 0, true);
  const Trajectory truth = Poses(*b);
  const double sent = Ate(truth, Poses(b_sent));

  const std::string db = dir + "/island_loops.db";
  std::string island;
  double solved = 0;
  {
    Running r = Start(db);
    ASSERT_TRUE(r.server);
    Stream(r.mapping.get(), "A", Rebased(*a, 0, false));
    island = Stream(r.mapping.get(), "B", b_sent);
    r.server->Flush();
    const loci::v1::SessionAlignment s = IslandSolved(r.query.get(), 1);
    ASSERT_FALSE(s.aligned()) << "room b is another place: B must stay an island";
    ASSERT_EQ(s.island(), island);
    const Trajectory in_island = IslandTrajectory(r.query.get(), island, "B");
    EXPECT_EQ(in_island.size(), b_sent.size());
    solved = Ate(truth, in_island);
    std::printf("B's keyframe ATE: sent %.4f m, in its island %.4f m (%zu keyframes); island "
                "graph solved %llu times, last: %llu loops kept, %llu rejected\n",
                sent, solved, in_island.size(),
                static_cast<unsigned long long>(s.island_optimizations()),
                static_cast<unsigned long long>(s.island_loops_accepted()),
                static_cast<unsigned long long>(s.island_loops_rejected()));
    EXPECT_GT(sent, 0.05);  // the drift is real
    EXPECT_LE(solved, sent / 3);
    EXPECT_GT(s.island_loops_accepted(), 0u);
    // An unknown island's trajectory: NOT_FOUND.
    grpc::ClientContext ctx;
    loci::v1::GetTrajectoriesRequest req;
    req.set_island("no-such-island");
    loci::v1::GetTrajectoriesResponse resp;
    EXPECT_EQ(r.query->GetTrajectories(&ctx, req, &resp).error_code(), grpc::StatusCode::NOT_FOUND);
  }
  // A restart maps the island again from B's odometry and its corrected placement, then solves
  // its graph once more.
  Running again = Start(db);
  ASSERT_TRUE(again.server);
  ASSERT_TRUE(again.server->WaitReady().ok());
  const loci::v1::SessionAlignment s = IslandSolved(again.query.get(), 1);
  EXPECT_GE(s.island_optimizations(), 1u);
  const double restarted = Ate(truth, IslandTrajectory(again.query.get(), island, "B"));
  std::printf("after a restart: B's keyframe ATE in its island %.4f m\n", restarted);
  EXPECT_LE(restarted, sent / 3);
  if (!::testing::Test::HasFailure()) fs::remove_all(dir);
}

}  // namespace
}  // namespace loci::server
