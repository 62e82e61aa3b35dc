// MapClient against the real loci-server binary on loopback: keyframes of the shipped fr1_rpy
// sample stream while the server is killed (SIGKILL) and restarted on the same port and
// database; at the end every keyframe must be stored exactly once, in one session.
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <thread>

#include "client/streaming/map_client.h"
#include "common/config.h"
#include "common/tum_io.h"

namespace loci {
namespace {

int FreePort() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr));
  socklen_t len = sizeof(addr);
  getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  close(fd);
  return ntohs(addr.sin_port);
}

pid_t StartServer(const std::string& listen, const std::string& db) {
  const pid_t pid = fork();
  if (pid == 0) {
    execl(LOCI_SERVER_BIN, LOCI_SERVER_BIN, "--listen", listen.c_str(), "--db", db.c_str(),
          "--log-level", "warn", static_cast<char*>(nullptr));
    _exit(127);
  }
  return pid;
}

void StopServer(pid_t pid, int sig) {
  if (pid <= 0) return;
  kill(pid, sig);
  int status = 0;
  waitpid(pid, &status, 0);
}

StatusOr<std::unique_ptr<MapClient>> ConnectWithRetry(const MapClientOptions& o,
                                                      const PinholeCamera& cam) {
  StatusOr<std::unique_ptr<MapClient>> c = absl::UnavailableError("not tried");
  for (int i = 0; i < 100; ++i) {
    c = MapClient::Connect(o, cam, 5000.0);
    if (c.ok()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return c;
}

class StreamingTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ =
        std::filesystem::temp_directory_path() / ("loci_stream_test_" + std::to_string(getpid()));
    std::filesystem::create_directories(dir_);
    db_ = (dir_ / "loci.db").string();
    listen_ = "127.0.0.1:" + std::to_string(FreePort());
  }
  void TearDown() override {
    StopServer(server_, SIGKILL);
    std::filesystem::remove_all(dir_);
  }
  std::filesystem::path dir_;
  std::string db_, listen_;
  pid_t server_ = -1;
};

TEST_F(StreamingTest, ServerKilledMidStreamEveryKeyframeStoredOnce) {
  auto seq = LoadTumSequence(SourceDir() + "/tests/data/tum_fr1_rpy_sample");
  ASSERT_TRUE(seq.ok()) << seq.status();
  server_ = StartServer(listen_, db_);
  MapClientOptions o;
  o.server = listen_;
  o.robot_name = "resume_bot";
  o.max_unacked = 6;
  auto client = ConnectWithRetry(o, PinholeCamera::TumFr1());
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
      StopServer(server_, SIGKILL);
      std::this_thread::sleep_for(std::chrono::milliseconds(300));
      server_ = StartServer(listen_, db_);
    }
  }
  const Status closed = (*client)->Close(90.0);
  EXPECT_TRUE(closed.ok()) << closed;
  const MapClientStats st = (*client)->stats();
  EXPECT_GE(st.reconnects, 1);
  EXPECT_EQ(st.rejected, 0) << st.last_error;
  EXPECT_EQ(st.queued, kKeyframes);
  StopServer(server_, SIGTERM);
  server_ = -1;

  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open_v2(db_.c_str(), &db, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
  auto count = [&](const char* sql) {
    sqlite3_stmt* st = nullptr;
    int64_t n = -1;
    if (sqlite3_prepare_v2(db, sql, -1, &st, nullptr) == SQLITE_OK &&
        sqlite3_step(st) == SQLITE_ROW) {
      n = sqlite3_column_int64(st, 0);
    }
    sqlite3_finalize(st);
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
  o.server = listen_;  // nothing listens there
  o.rpc_timeout_s = 0.5;
  auto c = MapClient::Connect(o, PinholeCamera::TumFr1(), 5000.0);
  EXPECT_FALSE(c.ok());
  o.max_unacked = 0;
  EXPECT_FALSE(MapClient::Connect(o, PinholeCamera::TumFr1(), 5000.0).ok());
}

}  // namespace
}  // namespace loci
