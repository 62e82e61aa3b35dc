// An island's own loop closure, on loopback gRPC: robot A maps one `loci synth`
// room (the shared map); robot B, whose odometry drifts (a steady yaw and translation drift,
// as a visual odometry's), swings its camera back and forth in another room for 30 s. B is never
// aligned, so its keyframes are mapped in an island of its own; the island's pose graph must
// close B's loops there: the keyframe ATE of the island's trajectory (GetTrajectories with the
// island) is at most a third of the drifted one B sent. A restart maps the island again at its
// stored corrected poses: the same trajectory, without solving again; matches no solve took in
// before a stop are solved at the next start. An island that joins B's is placed by B's
// corrected keyframes, and one aligned to the shared map enters it as its loops corrected it.
#include <gtest/gtest.h>
#include <unistd.h>

#include <spdlog/sinks/base_sink.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "common/trajectory_eval.h"
#include "proto/convert.h"
#include "server/runtime/proto_convert.h"
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

// The views as robot B sends them: drifted by 0.5 deg/s and 8 mm/s, its odometry starting at the
// identity at its first view.
std::vector<loci::v1::Keyframe> SentByB(const std::vector<loci::v1::Keyframe>& views) {
  return Rebased(Drifted(views, 0.5, Vec3d(0.006, -0.005, 0)), 0, true);
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

// B's session in the stats. Read after Flush, it holds every solve of B's island that B's
// keyframes made due: the aligning thread solves a graph and applies the solution before it
// counts the keyframe as recognised, and Flush waits for that count.
loci::v1::SessionAlignment SessionOfB(loci::v1::Query::Stub* stub) {
  return SessionsByRobot(Stats(stub))["B"];
}

// The lines spdlog logs while alive, added to the default logger's sinks (which go on writing as
// before): a wait on what the server does on a thread of its own, such as the solve at a start,
// wakes on the line it logs when done. Made and destroyed while no server runs (the default
// logger is swapped).
class LogLines {
 public:
  LogLines() : previous_(spdlog::default_logger()) {
    std::vector<spdlog::sink_ptr> sinks = previous_->sinks();
    sinks.push_back(lines_);
    auto logger = std::make_shared<spdlog::logger>("loci-test", sinks.begin(), sinks.end());
    logger->set_level(spdlog::level::info);  // the lines waited on are info
    spdlog::set_default_logger(logger);
  }
  ~LogLines() { spdlog::set_default_logger(previous_); }
  LogLines(const LogLines&) = delete;
  LogLines& operator=(const LogLines&) = delete;

  // Blocks until a line holding `needle` was logged, for at most `timeout`; whether one was.
  bool WaitFor(const std::string& needle, std::chrono::seconds timeout) {
    return lines_->WaitFor(needle, timeout);
  }

 private:
  class Sink : public spdlog::sinks::base_sink<std::mutex> {
   public:
    bool WaitFor(const std::string& needle, std::chrono::seconds timeout) {
      std::unique_lock<std::mutex> lock(mu_);
      return cv_.wait_for(lock, timeout,
                          [&] { return text_.find(needle) != std::string::npos; });
    }

   protected:
    void sink_it_(const spdlog::details::log_msg& msg) override {
      {
        std::lock_guard<std::mutex> lock(mu_);
        text_.append(msg.payload.data(), msg.payload.size());
        text_ += '\n';
      }
      cv_.notify_all();
    }
    void flush_() override {}

   private:
    std::mutex mu_;
    std::condition_variable cv_;
    std::string text_;
  };
  std::shared_ptr<spdlog::logger> previous_;
  std::shared_ptr<Sink> lines_ = std::make_shared<Sink>();
};

// Rooms a (45 views) and b (150 views) of `loci synth`, written to a fresh folder `name`<pid>
// (left empty when writing or reading them failed).
struct TwoRooms {
  std::string dir;
  std::vector<loci::v1::Keyframe> a, b;
};
TwoRooms WriteRooms(const std::string& name) {
  TwoRooms rooms;
  rooms.dir = ::testing::TempDir() + "/" + name + std::to_string(getpid());
  fs::remove_all(rooms.dir);
  fs::create_directories(rooms.dir);
  if (!synth::WriteSequence(Room(2), rooms.dir + "/a").ok() ||
      !synth::WriteSequence(Room(1, 150), rooms.dir + "/b").ok()) {
    return rooms;
  }
  auto a = testing::LoadSceneKeyframes(rooms.dir + "/a");
  auto b = testing::LoadSceneKeyframes(rooms.dir + "/b");
  if (a.ok() && b.ok()) {
    rooms.a = std::move(*a);
    rooms.b = std::move(*b);
  }
  return rooms;
}

TEST(IslandLoops, AnUnalignedRobotsDriftIsCutToAThirdInItsIsland) {
  const TwoRooms rooms = WriteRooms("loci_island_loops_");
  ASSERT_FALSE(rooms.a.empty() || rooms.b.empty());
  const std::string& dir = rooms.dir;
  const std::vector<loci::v1::Keyframe>& a = rooms.a;
  const std::vector<loci::v1::Keyframe>& b = rooms.b;
  const std::vector<loci::v1::Keyframe> b_sent = SentByB(b);
  const Trajectory truth = Poses(b);
  const double sent = Ate(truth, Poses(b_sent));

  const std::string db = dir + "/island_loops.db";
  std::string island;
  double solved = 0;
  Trajectory in_island;
  {
    Running r = Start(db);
    ASSERT_TRUE(r.server);
    Stream(r.mapping.get(), "A", Rebased(a, 0, false));
    island = Stream(r.mapping.get(), "B", b_sent);
    r.server->Flush();
    const loci::v1::SessionAlignment s = SessionOfB(r.query.get());
    ASSERT_FALSE(s.aligned()) << "room b is another place: B must stay an island";
    ASSERT_EQ(s.island(), island);
    in_island = IslandTrajectory(r.query.get(), island, "B");
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
  // A restart maps the island again at its stored corrected poses (those newer than its last
  // solve at B's corrected placement): the same island, with no solve.
  Running again = Start(db);
  ASSERT_TRUE(again.server);
  ASSERT_TRUE(again.server->readiness().Wait().ok());
  const Trajectory reloaded = IslandTrajectory(again.query.get(), island, "B");
  ASSERT_EQ(reloaded.size(), in_island.size());
  const double restarted = Ate(truth, reloaded), moved = Ate(in_island, reloaded);
  std::printf("after a restart: B's keyframe ATE in its island %.4f m, %.6f m from before\n",
              restarted, moved);
  EXPECT_LE(restarted, sent / 3);
  EXPECT_LT(moved, 1e-4);
  EXPECT_EQ(SessionsByRobot(Stats(again.query.get()))["B"].island_optimizations(), 0u);
  if (!::testing::Test::HasFailure()) fs::remove_all(dir);
}

// The server stops before B's island was ever solved (the graph kept from solving while B
// streamed): its matches are stored, its keyframes have no corrected pose. The next start must
// solve them at load, not wait for keyframes that may never come.
TEST(IslandLoops, MatchesLeftUnsolvedAtAStopAreSolvedAtTheNextStart) {
  const TwoRooms rooms = WriteRooms("loci_island_pending_");
  ASSERT_FALSE(rooms.a.empty() || rooms.b.empty());
  const std::vector<loci::v1::Keyframe> b_sent = SentByB(rooms.b);
  const Trajectory truth = Poses(rooms.b);
  const double sent = Ate(truth, Poses(b_sent));
  const std::string db = rooms.dir + "/island_pending.db";
  std::string island;
  {
    ServerOptions o = testing::Options();
    o.align.loops.optimize_min_keyframes = 1'000'000;  // never due while it runs
    Running r = Start(db, o);
    ASSERT_TRUE(r.server);
    Stream(r.mapping.get(), "A", Rebased(rooms.a, 0, false));
    island = Stream(r.mapping.get(), "B", b_sent);
    r.server->Flush();
    const loci::v1::SessionAlignment s = SessionsByRobot(Stats(r.query.get()))["B"];
    ASSERT_FALSE(s.aligned());
    ASSERT_EQ(s.island_optimizations(), 0u);
  }
  // The solve at the start runs on the loading thread once the map is ready: the wait is on the
  // line the server logs when it has applied it.
  LogLines log;
  Running again = Start(db);
  ASSERT_TRUE(again.server);
  ASSERT_TRUE(again.server->readiness().Wait().ok());
  EXPECT_TRUE(log.WaitFor("island " + island + "'s pose graph:", std::chrono::seconds(60)))
      << "B's island was not solved at the start";
  const loci::v1::SessionAlignment s = SessionOfB(again.query.get());
  const Trajectory in_island = IslandTrajectory(again.query.get(), island, "B");
  ASSERT_EQ(in_island.size(), b_sent.size());
  const double solved = Ate(truth, in_island);
  std::printf("B's keyframe ATE: sent %.4f m; its island solved %llu times after the restart, "
              "no keyframe sent: %.4f m\n",
              sent, static_cast<unsigned long long>(s.island_optimizations()), solved);
  EXPECT_GE(s.island_optimizations(), 1u);
  EXPECT_LE(solved, sent / 3);
  if (!::testing::Test::HasFailure()) fs::remove_all(rooms.dir);
}

// Robot C (no drift) walks the end of room b after B's island closed its loops: C's island
// joins B's, placed from where B's matched keyframes are mapped in the island (corrected), not
// from B's drifted odometry x its placement. Both robots' keyframes in the island then make one
// trajectory: their joint ATE stays that of B's island. The island's graph is kept from
// solving again (optimize_min_keyframes 120 > C's 50 keyframes), so the test reads the join.
TEST(IslandLoops, AnIslandJoiningAnotherIsPlacedByItsCorrectedKeyframes) {
  const TwoRooms rooms = WriteRooms("loci_island_join_");
  ASSERT_FALSE(rooms.a.empty() || rooms.b.empty());
  const std::vector<loci::v1::Keyframe> b_sent = SentByB(rooms.b);
  const std::vector<loci::v1::Keyframe> c_sent = Rebased(rooms.b, 100, true);
  const Trajectory truth = Poses(rooms.b);
  ServerOptions o = testing::Options();
  o.align.loops.optimize_min_keyframes = 120;
  Running r = Start(rooms.dir + "/island_join.db", o);
  ASSERT_TRUE(r.server);
  Stream(r.mapping.get(), "A", Rebased(rooms.a, 0, false));
  const std::string island = Stream(r.mapping.get(), "B", b_sent);
  r.server->Flush();
  ASSERT_GE(SessionOfB(r.query.get()).island_optimizations(), 1u);
  const Trajectory b_island = IslandTrajectory(r.query.get(), island, "B");
  Stream(r.mapping.get(), "C", c_sent);
  r.server->Flush();
  const auto sessions = SessionsByRobot(Stats(r.query.get()));
  ASSERT_FALSE(sessions.at("C").aligned());
  ASSERT_EQ(sessions.at("C").island(), island) << "C's island did not join B's";
  ASSERT_EQ(sessions.at("B").island_optimizations(), 1u) << "B's island solved again: the test "
                                                            "reads that solve, not the join";
  // One trajectory of both robots (C's keyframes stamped apart from B's) against the truth.
  Trajectory joint = IslandTrajectory(r.query.get(), island, "B");
  Trajectory joint_truth = truth;
  const int64_t c_shift_ns = 3'600'000'000'000;
  const Trajectory c_island = IslandTrajectory(r.query.get(), island, "C");
  ASSERT_EQ(c_island.size(), c_sent.size());
  for (const auto& p : c_island) joint.push_back({p.t_ns + c_shift_ns, p.T_world_cam});
  for (size_t i = 100; i < truth.size(); ++i) {
    joint_truth.push_back({truth[i].t_ns + c_shift_ns, truth[i].T_world_cam});
  }
  const double b_ate = Ate(truth, b_island), joint_ate = Ate(joint_truth, joint);
  std::printf("B's keyframe ATE in its island %.4f m; B and C together after C joined %.4f m\n",
              b_ate, joint_ate);
  EXPECT_LE(joint_ate, 2 * b_ate + 0.005);
  if (!::testing::Test::HasFailure()) fs::remove_all(rooms.dir);
}

// B's keyframes in the shared map (its robot's trajectory there), up to t_last_ns.
Trajectory SharedTrajectory(loci::v1::Query::Stub* stub, const std::string& robot,
                            int64_t t_last_ns) {
  grpc::ClientContext ctx;
  loci::v1::GetTrajectoriesResponse resp;
  EXPECT_TRUE(stub->GetTrajectories(&ctx, {}, &resp).ok());
  Trajectory out;
  for (const loci::v1::Trajectory& t : resp.trajectories()) {
    if (t.robot() != robot) continue;
    for (const loci::v1::StampedPose& p : t.poses()) {
      if (p.t_ns() <= t_last_ns) out.push_back({p.t_ns(), PoseFromProto(p.t_map_cam())});
    }
  }
  return out;
}

// Robot B drifts through room b as above, its island closes its loops, then B walks on into
// room a (6 m and 0.3 rad away in the world), where robot A mapped: B is aligned and its island
// dropped. The keyframes B held back must enter the shared map where its island's loop closure
// put them, not at its drifted odometry. The shared graph is kept from solving (at most 120
// keyframes per solve: A brings 45, B's island's pending ones and room a about 40), so what the
// test reads is the merge itself.
TEST(IslandLoops, AnAlignedIslandEntersTheSharedMapAsItsLoopsCorrectedIt) {
  const TwoRooms rooms = WriteRooms("loci_island_merge_");
  ASSERT_FALSE(rooms.a.empty() || rooms.b.empty());
  const std::string& dir = rooms.dir;
  const std::vector<loci::v1::Keyframe>& a = rooms.a;
  const std::vector<loci::v1::Keyframe>& b = rooms.b;
  // B's true path in room b's world: room b, then room a's views 10.. placed at T_b_a.
  const SE3d T_b_a = MakeSE3(Vec3d(6.0, 0.0, 0.0), Quatd(Eigen::AngleAxisd(0.3, Vec3d::UnitZ())));
  std::vector<loci::v1::Keyframe> path = b;
  int64_t t_ns = path.back().t_ns();
  for (size_t i = 10; i < a.size(); ++i) {
    loci::v1::Keyframe kf = a[i];
    t_ns += 200'000'000;
    kf.set_t_ns(t_ns);
    ToProto(T_b_a * PoseFromProto(kf.t_odom_cam()), kf.mutable_t_odom_cam());
    path.push_back(kf);
  }
  const std::vector<loci::v1::Keyframe> sent = SentByB(path);
  const auto room_a_start = sent.begin() + static_cast<std::ptrdiff_t>(b.size());
  const int64_t t_room_b_end_ns = b.back().t_ns();
  const Trajectory truth = Poses(b);

  ServerOptions o = testing::Options();
  o.align.loops.optimize_min_keyframes = 120;
  Running r = Start(dir + "/island_merge.db", o);
  ASSERT_TRUE(r.server);
  Stream(r.mapping.get(), "A", Rebased(a, 0, false));
  const std::string island = Stream(r.mapping.get(), "B", {sent.begin(), room_a_start});
  r.server->Flush();
  const loci::v1::SessionAlignment in_b = SessionOfB(r.query.get());
  ASSERT_FALSE(in_b.aligned());
  ASSERT_GE(in_b.island_optimizations(), 1u);
  const Trajectory in_island = IslandTrajectory(r.query.get(), island, "B");
  testing::StreamInto(r.mapping.get(), island, {room_a_start, sent.end()},
                      static_cast<int64_t>(b.size()));
  r.server->Flush();
  const loci::v1::GetStatsResponse stats = Stats(r.query.get());
  ASSERT_TRUE(SessionsByRobot(stats)["B"].aligned()) << "B did not align in room a";
  ASSERT_EQ(stats.pose_graph().optimizations(), 0u) << "the shared graph solved: the test reads "
                                                       "that solve, not the merge";
  const Trajectory shared = SharedTrajectory(r.query.get(), "B", t_room_b_end_ns);
  ASSERT_EQ(shared.size(), in_island.size());
  const double sent_ate = Ate(truth, Poses({sent.begin(), room_a_start}));
  const double island_ate = Ate(truth, in_island), shared_ate = Ate(truth, shared);
  // The island's shape, rigidly moved: the same trajectory up to float rounding.
  const double from_island = Ate(in_island, shared);
  std::printf("B's room-b keyframes, ATE: sent %.4f m, in its island %.4f m, in the shared map "
              "after the merge %.4f m (%.5f m from the island's)\n",
              sent_ate, island_ate, shared_ate, from_island);
  EXPECT_LT(from_island, 1e-3);
  EXPECT_LE(shared_ate, sent_ate / 3);
  if (!::testing::Test::HasFailure()) fs::remove_all(dir);
}

}  // namespace
}  // namespace loci::server
