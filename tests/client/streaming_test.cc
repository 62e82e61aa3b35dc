// MapClient against the real loci-server binary on loopback: keyframes of the shipped fr1_rpy
// sample stream while the server is killed (SIGKILL) and restarted on the same port and
// database; at the end every keyframe must be stored exactly once, in one session.
#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <memory>
#include <thread>
#include <opencv2/imgcodecs.hpp>

#include "client/streaming/map_client.h"
#include "common/config.h"
#include "common/tum_io.h"
#include "tests/support/server_process.h"

namespace loci {
namespace {

class StreamingTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ =
        std::filesystem::temp_directory_path() / ("loci_stream_test_" + std::to_string(getpid()));
    std::filesystem::create_directories(dir_);
    db_ = (dir_ / "loci.db").string();
  }
  void TearDown() override {
    server_.reset();
    std::filesystem::remove_all(dir_);
  }
  // Starts loci-server on `listen` and waits for its "listening on" line.
  void StartServer(const std::string& listen) {
    server_ = std::make_unique<testing::ServerProcess>(
        testing::ServerProcessOptions{.db = db_, .listen = listen});
  }
  std::filesystem::path dir_;
  std::string db_;
  std::unique_ptr<testing::ServerProcess> server_;
};

TEST_F(StreamingTest, ServerKilledMidStreamEveryKeyframeStoredOnce) {
  auto seq = LoadTumSequence(SourceDir() + "/tests/data/tum_fr1_rpy_sample");
  ASSERT_TRUE(seq.ok()) << seq.status();
  StartServer("127.0.0.1:0");
  ASSERT_GT(server_->port(), 0) << "loci-server did not print its port";
  const std::string listen = server_->address();  // the restart binds the same port
  MapClientOptions o;
  o.server = listen;
  o.robot_name = "resume_bot";
  o.max_unacked = 6;
  auto client = MapClient::Connect(o, PinholeCamera::TumFr1(), 5000.0);
  ASSERT_TRUE(client.ok()) << client.status();

  const int kKeyframes = 20;
  size_t gt = 0;
  for (int k = 0; k < kKeyframes; ++k) {
    const TumFrame& f = seq->frames[static_cast<size_t>(k) * 3];
    KeyframeData kf;
    kf.t_ns = f.rgb_t_ns;
    while (gt + 1 < seq->groundtruth.size() && seq->groundtruth[gt + 1].t_ns <= f.rgb_t_ns) ++gt;
    kf.T_odom_cam = seq->groundtruth[gt].T_world_cam;
    kf.bgr = cv::imread(f.rgb_path, cv::IMREAD_COLOR);
    kf.depth_u16 = cv::imread(f.depth_path, cv::IMREAD_UNCHANGED);
    if (auto g = GravityInCamAt(seq->accel, f.rgb_t_ns); g.ok()) kf.gravity_cam = *g;
    auto s = (*client)->Send(std::move(kf));
    ASSERT_TRUE(s.ok()) << s.status();
    EXPECT_EQ(*s, k);
    if (k == 7) {
      // Mid-stream: some keyframes acknowledged, some in flight, more to come.
      server_->Stop(SIGKILL);
      StartServer(listen);
      ASSERT_GT(server_->port(), 0) << "restart on " << listen;
    }
  }
  const Status closed = (*client)->Close(90.0);
  EXPECT_TRUE(closed.ok()) << closed;
  const MapClientStats st = (*client)->stats();
  EXPECT_GE(st.reconnects, 1);
  EXPECT_EQ(st.rejected, 0) << st.last_error;
  EXPECT_EQ(st.queued, kKeyframes);
  const int exit_status = server_->Stop(SIGTERM);
  EXPECT_TRUE(WIFEXITED(exit_status) && WEXITSTATUS(exit_status) == 0) << exit_status;

  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open_v2(db_.c_str(), &db, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
  auto count = [&](const char* sql) {
    sqlite3_stmt* stmt = nullptr;
    int64_t n = -1;
    if (sqlite3_prepare_v2(db, sql, -1, &stmt, nullptr) == SQLITE_OK &&
        sqlite3_step(stmt) == SQLITE_ROW) {
      n = sqlite3_column_int64(stmt, 0);
    }
    sqlite3_finalize(stmt);
    return n;
  };
  EXPECT_EQ(count("SELECT COUNT(*) FROM keyframes"), kKeyframes);
  EXPECT_EQ(count("SELECT COUNT(DISTINCT seq) FROM keyframes"), kKeyframes);
  EXPECT_EQ(count("SELECT MIN(seq) FROM keyframes"), 0);
  EXPECT_EQ(count("SELECT MAX(seq) FROM keyframes"), kKeyframes - 1);
  EXPECT_EQ(count("SELECT COUNT(DISTINCT session) FROM keyframes"), 1);
  EXPECT_EQ(count("SELECT COUNT(*) FROM keyframes WHERE has_gravity = 1"), kKeyframes);
  sqlite3_close(db);
}

TEST_F(StreamingTest, UnreachableServerFailsCleanly) {
  MapClientOptions o;
  o.server = "127.0.0.1:1";  // tcpmux: nothing listens there
  o.rpc_timeout_s = 0.5;
  o.connect_timeout_s = 1.0;
  auto c = MapClient::Connect(o, PinholeCamera::TumFr1(), 5000.0);
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.status().code(), absl::StatusCode::kUnavailable) << c.status();
}

// loci-track started before loci-server (a robot booting with the fleet's server): Connect
// waits for the server instead of giving up on its first attempt.
TEST_F(StreamingTest, ConnectWaitsForAServerThatIsStillStarting) {
  StartServer("127.0.0.1:0");
  ASSERT_GT(server_->port(), 0);
  const std::string listen = server_->address();
  server_.reset();  // the port is free again: nothing listens while Connect starts
  MapClientOptions o;
  o.server = listen;
  o.connect_timeout_s = 60.0;
  StatusOr<std::unique_ptr<MapClient>> client = absl::UnknownError("not run");
  std::thread connecting([&] { client = MapClient::Connect(o, PinholeCamera::TumFr1(), 5000.0); });
  StartServer(listen);
  connecting.join();
  ASSERT_GT(server_->port(), 0);
  ASSERT_TRUE(client.ok()) << client.status();
  EXPECT_FALSE((*client)->session_id().empty());
}

TEST_F(StreamingTest, NoSendWindowIsRejectedBeforeConnecting) {
  StartServer("127.0.0.1:0");  // reachable: only the option can make Connect fail
  ASSERT_GT(server_->port(), 0);
  MapClientOptions o;
  o.server = server_->address();
  ASSERT_TRUE(MapClient::Connect(o, PinholeCamera::TumFr1(), 5000.0).ok());
  o.max_unacked = 0;
  const auto c = MapClient::Connect(o, PinholeCamera::TumFr1(), 5000.0);
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.status().code(), absl::StatusCode::kInvalidArgument) << c.status();
}

}  // namespace
}  // namespace loci
