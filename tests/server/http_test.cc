// The HTTP API's web-viewer side in process on loopback: the viewer's static files (content
// types, nothing outside the viewer folder, 404 JSON), /api/cloud and /api/trajectories equal to
// the QueryService calls, the /api/events stream (an event per object change, the client cap
// answered 503, a client that leaves frees its slot, shutdown with a stream open), and tokens
// (static files free, /api needs one); Range only for the viewer's files.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "proto/json.h"
#include "server/http/http_api.h"
#include "server/service/grpc_server.h"
#include "server/runtime/map_server.h"
#include "tests/server/box_world.h"
#include "tests/server/keyframe_proto.h"

// Last: httplib pulls <resolv.h>, whose `_res` macro breaks Eigen headers included after it.
#include <httplib.h>

namespace loci::server {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

int64_t StampNs(int i) { return 1'700'000'000'000'000'000 + 1'000'000'000LL * (i + 1); }

void WriteFile(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path) << text;
}

// A GET /api/events client on its own thread, recording the status and the text received.
class EventClient {
 public:
  explicit EventClient(int port) : thread_([this, port] { Run(port); }) {}
  ~EventClient() { Close(); }
  EventClient(const EventClient&) = delete;
  EventClient& operator=(const EventClient&) = delete;

  // Leaves: the next chunk (a keep-alive at the latest) cancels the download.
  void Close() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }
  // Waits until the text holds `needle` or the connection ended; whether it holds it.
  bool WaitFor(const std::string& needle, std::chrono::seconds timeout = std::chrono::seconds(30)) {
    std::unique_lock<std::mutex> lock(mu_);
    cv_.wait_for(lock, timeout,
                 [&] { return done_ || text_.find(needle) != std::string::npos; });
    return text_.find(needle) != std::string::npos;
  }
  bool WaitDone(std::chrono::seconds timeout) {
    std::unique_lock<std::mutex> lock(mu_);
    return cv_.wait_for(lock, timeout, [&] { return done_; });
  }
  int status() {
    std::lock_guard<std::mutex> lock(mu_);
    return status_;
  }
  std::string text() {
    std::lock_guard<std::mutex> lock(mu_);
    return text_;
  }

 private:
  void Run(int port) {
    httplib::Client client("127.0.0.1", port);
    client.set_read_timeout(30, 0);
    client.Get(
        "/api/events",
        [this](const httplib::Response& r) {
          std::lock_guard<std::mutex> lock(mu_);
          status_ = r.status;
          return true;
        },
        [this](const char* data, size_t n) {
          std::lock_guard<std::mutex> lock(mu_);
          text_.append(data, n);
          cv_.notify_all();
          return !stop_;
        });
    std::lock_guard<std::mutex> lock(mu_);
    done_ = true;
    cv_.notify_all();
  }

  std::atomic<bool> stop_{false};
  std::mutex mu_;
  std::condition_variable cv_;
  int status_ = 0;
  std::string text_;
  bool done_ = false;
  std::thread thread_;
};

class HttpViewerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) /
           ("loci_http_" + std::string(::testing::UnitTest::GetInstance()
                                           ->current_test_info()->name()));
    fs::remove_all(dir_);
    WriteFile(dir_ / "viewer/index.html", "<!doctype html><title>loci</title>");
    WriteFile(dir_ / "viewer/app/main.js", "export const answer = 42;\n");
    WriteFile(dir_ / "viewer/viewer.css", "body { margin: 0; }\n");
    WriteFile(dir_ / "secret.txt", "not for the web");
    const auto boxes = testing::DefaultBoxes(false);
    poses_ = testing::ArcPoses(4);
    for (const SE3d& pose : poses_) views_.push_back(testing::Render(boxes, camera_, pose, true));
  }
  void TearDown() override {
    http_.reset();
    grpc_.reset();
    server_.reset();
    fs::remove_all(dir_);
  }

  void Start(int max_event_clients = 8, Authorizer auth = {}) {
    ServerOptions o;
    o.db_path = (dir_ / "map.db").string();
    o.map.mapped_classes = {"book", "cup", "laptop"};
    auto s = MapServer::Open(o);
    ASSERT_TRUE(s.ok()) << s.status();
    server_ = std::move(*s);
    auto g = GrpcServer::Start(server_.get(), "127.0.0.1:0", o.max_message_mb, nullptr,
                               std::move(auth));
    ASSERT_TRUE(g.ok()) << g.status();
    grpc_ = std::move(*g);
    const HttpOptions ho{.viewer_dir = (dir_ / "viewer").string(),
                         .max_event_clients = max_event_clients};
    auto h = HttpApi::Start(grpc_->query_service(), "127.0.0.1:0", &grpc_->auth(), {}, ho);
    ASSERT_TRUE(h.ok()) << h.status();
    http_ = std::move(*h);
    client_ = std::make_unique<httplib::Client>("127.0.0.1", http_->port());
  }

  // Streams keyframes [first, last) of the views; mapped before it returns when `flush`.
  void Ingest(int first, int last, bool flush = true) {
    if (session_.empty()) {
      auto open = server_->OpenSession(testing::OpenRequest("robot1", camera_));
      ASSERT_TRUE(open.ok()) << open.status();
      session_ = open->session_id();
    }
    for (int i = first; i < last; ++i) {
      const auto ack = server_->Ingest(testing::MakeKeyframe(
          session_, i, StampNs(i), poses_[i], views_[i].bgr, views_[i].depth_u16,
          views_[i].detections, poses_[i].rotation().transpose() * Eigen::Vector3d(0, 0, -1)));
      ASSERT_EQ(ack.status().code(), 0) << ack.status().message();
    }
    if (flush) server_->Flush();
  }

  std::pair<int, std::string> Get(const std::string& path) {
    auto res = client_->Get(path.c_str());
    if (!res) return {-1, ""};
    return {res->status, res->body};
  }

  fs::path dir_;
  PinholeCamera camera_ = PinholeCamera::TumFr1();
  std::vector<SE3d> poses_;
  std::vector<testing::RenderedView> views_;
  std::string session_;
  std::unique_ptr<MapServer> server_;
  std::unique_ptr<GrpcServer> grpc_;
  std::unique_ptr<HttpApi> http_;
  std::unique_ptr<httplib::Client> client_;
};

TEST_F(HttpViewerTest, ServesTheViewerReadOnlyWithContentTypes) {
  Start();
  const std::pair<const char*, const char*> files[] = {
      {"/", "text/html; charset=utf-8"},
      {"/index.html", "text/html; charset=utf-8"},
      {"/app/main.js", "text/javascript; charset=utf-8"},
      {"/viewer.css", "text/css; charset=utf-8"}};
  for (const auto& [path, type] : files) {
    auto res = client_->Get(path);
    ASSERT_TRUE(res) << path;
    EXPECT_EQ(res->status, 200) << path;
    EXPECT_EQ(res->get_header_value("Content-Type"), type) << path;
    EXPECT_EQ(res->get_header_value("X-Content-Type-Options"), "nosniff") << path;
  }
  EXPECT_EQ(Get("/app/main.js").second, "export const answer = 42;\n");
  for (const char* path : {"/../secret.txt", "/app/../../secret.txt", "/%2e%2e/secret.txt",
                           "/app/%2e%2e/%2e%2e/secret.txt", "/..%2fsecret.txt", "/app",
                           "/nothing.html"}) {
    const auto [status, body] = Get(path);
    EXPECT_GE(status, 400) << path;
    EXPECT_EQ(body.find("not for the web"), std::string::npos) << path;
    EXPECT_NE(body.find("\"error\""), std::string::npos) << path << ": " << body;
  }
  const auto [status, body] = Get("/nothing.html");
  EXPECT_EQ(status, 404);
  EXPECT_NE(body.find("\"NOT_FOUND\""), std::string::npos) << body;
  auto post = client_->Post("/index.html", "x", "text/plain");
  ASSERT_TRUE(post);
  EXPECT_GE(post->status, 400);
  EXPECT_EQ(post->body.find("<title>"), std::string::npos);
}

TEST_F(HttpViewerTest, MissingViewerFolderIsRefusedAtStart) {
  ServerOptions options;
  options.db_path = (dir_ / "m.db").string();
  auto s = MapServer::Open(options);
  ASSERT_TRUE(s.ok());
  auto g = GrpcServer::Start(s->get(), "127.0.0.1:0", 64);
  ASSERT_TRUE(g.ok());
  HttpOptions http_options;
  http_options.viewer_dir = (dir_ / "nowhere").string();
  auto h = HttpApi::Start((*g)->query_service(), "127.0.0.1:0", nullptr, {}, http_options);
  EXPECT_EQ(h.status().code(), absl::StatusCode::kInvalidArgument);
}

TEST_F(HttpViewerTest, CloudTrajectoriesAndStatsMatchTheQueryService) {
  Start();
  Ingest(0, 4);
  loci::v1::GetCloudRequest cloud_req;
  cloud_req.set_voxel_m(0.05);
  loci::v1::GetCloudResponse cloud;
  ASSERT_TRUE(grpc_->query_service()->GetCloud(cloud_req, &cloud).ok());
  ASSERT_GT(cloud.points_size(), 100);
  EXPECT_EQ(Get("/api/cloud?voxel_m=0.05").second, ProtoToJson(cloud));
  EXPECT_EQ(Get("/api/cloud").second, ProtoToJson(cloud));  // 0.05 m by default
  const auto [cup_status, cup_body] = Get("/api/cloud?class=cup");
  EXPECT_EQ(cup_status, 200);
  EXPECT_LT(cup_body.size(), Get("/api/cloud?voxel_m=0").second.size());
  for (const char* bad : {"/api/cloud?voxel_m=-1", "/api/cloud?voxel_m=abc",
                          "/api/cloud?voxel_m=inf"}) {
    EXPECT_EQ(Get(bad).first, 400) << bad;
  }

  loci::v1::GetTrajectoriesResponse traj;
  ASSERT_TRUE(grpc_->query_service()->GetTrajectories({}, &traj).ok());
  ASSERT_EQ(traj.trajectories_size(), 1);
  EXPECT_EQ(traj.trajectories(0).poses_size(), 4);
  EXPECT_EQ(Get("/api/trajectories").second, ProtoToJson(traj));
  EXPECT_EQ(Get("/api/trajectories?robot=nobody").second, "{\"trajectories\":[]}");

  loci::v1::GetStatsResponse stats;
  ASSERT_TRUE(JsonToProto(Get("/api/stats").second, &stats).ok());
  EXPECT_EQ(stats.keyframes(), 4u);
  EXPECT_EQ(stats.mapped_keyframes(), 4u);
}

TEST_F(HttpViewerTest, EventStreamSendsObjectChanges) {
  Start();
  EventClient events(http_->port());
  ASSERT_TRUE(events.WaitFor("event: ready")) << events.text();
  EXPECT_EQ(events.status(), 200);
  Ingest(0, 2);
  ASSERT_TRUE(events.WaitFor("\"kind\":\"CREATED\"")) << events.text();
  // Each `event: object` carries one ObjectEvent as proto3 JSON on its data line.
  const std::string text = events.text();
  const size_t at = text.find("event: object\ndata: ");
  ASSERT_NE(at, std::string::npos) << text;
  const size_t begin = at + std::string("event: object\ndata: ").size();
  loci::v1::ObjectEvent e;
  ASSERT_TRUE(JsonToProto(text.substr(begin, text.find('\n', begin) - begin), &e).ok());
  EXPECT_GT(e.object().id(), 0);
  EXPECT_FALSE(e.object().class_name().empty());
  EXPECT_GT(e.t_ns(), 0);
  EXPECT_TRUE(events.WaitFor(": keep-alive")) << "no keep-alive while idle";
}

TEST_F(HttpViewerTest, EventClientsAreCappedAndALeavingClientFreesItsSlot) {
  Start(/*max_event_clients=*/2);
  auto first = std::make_unique<EventClient>(http_->port());
  EventClient second(http_->port());
  ASSERT_TRUE(first->WaitFor("event: ready"));
  ASSERT_TRUE(second.WaitFor("event: ready"));
  {
    EventClient third(http_->port());
    ASSERT_TRUE(third.WaitDone(std::chrono::seconds(10)));
    EXPECT_EQ(third.status(), 503);
    EXPECT_NE(third.text().find("\"UNAVAILABLE\""), std::string::npos) << third.text();
    EXPECT_NE(third.text().find("max_event_clients"), std::string::npos) << third.text();
  }
  EXPECT_EQ(Get("/api/stats").first, 200);  // the API still answers with the streams open
  first->Close();
  first.reset();
  // The server notices the departure at its next keep-alive write: a new client gets the slot.
  const auto deadline = Clock::now() + std::chrono::seconds(10);
  bool admitted = false;
  while (!admitted && Clock::now() < deadline) {
    EventClient again(http_->port());
    admitted = again.WaitFor("event: ready", std::chrono::seconds(5));
  }
  EXPECT_TRUE(admitted) << "the slot of a client that left was not freed";
}

TEST_F(HttpViewerTest, ShutdownEndsOpenEventStreams) {
  Start();
  EventClient events(http_->port());
  ASSERT_TRUE(events.WaitFor("event: ready"));
  http_->Shutdown();  // ends the open event streams, then stops serving
  EXPECT_TRUE(events.WaitDone(std::chrono::seconds(10)));
}

// An error reply as the API sends it: {"error": {"code": "...", "message": "..."}}.
bool IsErrorJson(const std::string& body) {
  const auto j = nlohmann::json::parse(body, nullptr, /*allow_exceptions=*/false);
  return j.is_object() && j.contains("error") && j["error"].is_object() &&
         j["error"].contains("code") && j["error"]["code"].is_string() &&
         j["error"].contains("message") && j["error"]["message"].is_string();
}

// Regression (fuzz_http): cpp-httplib 0.11 cut every reply to the request's Range header and
// kept its status, so `Range: bytes=0-5` turned /api/stats into 200 `{"sess` and error replies
// into cut JSON. Only the viewer's files honour Range now.
TEST_F(HttpViewerTest, RangeIsHonouredForViewerFilesOnly) {
  Start();
  auto file = client_->Get("/app/main.js", {{"Range", "bytes=0-5"}});
  ASSERT_TRUE(file);
  EXPECT_EQ(file->status, 206);
  EXPECT_EQ(file->body, "export");
  for (const char* range : {"bytes=0-5", "bytes=0-5,8-9", "bytes=-3"}) {
    auto stats = client_->Get("/api/stats", {{"Range", range}});
    ASSERT_TRUE(stats) << range;
    EXPECT_EQ(stats->status, 200) << range;
    EXPECT_FALSE(stats->has_header("Content-Range")) << range;
    loci::v1::GetStatsResponse parsed;
    EXPECT_TRUE(JsonToProto(stats->body, &parsed).ok()) << range << ": " << stats->body;
    for (const char* path : {"/nothing.html", "/api/nothing", "/api/objects/abc",
                             "/api/cloud?voxel_m=-1"}) {
      auto error = client_->Get(path, {{"Range", range}});
      ASSERT_TRUE(error) << path;
      EXPECT_GE(error->status, 400) << path;
      EXPECT_TRUE(IsErrorJson(error->body)) << path << " " << range << ": " << error->body;
    }
  }
}

TEST_F(HttpViewerTest, WithTokensStaticFilesAreFreeAndTheApiIsNot) {
  WriteFile(dir_ / "tokens.txt", "viewer-query-token-0123 query\n");
  auto auth = Authorizer::FromFile((dir_ / "tokens.txt").string());
  ASSERT_TRUE(auth.ok()) << auth.status();
  Start(8, std::move(*auth));
  EXPECT_EQ(Get("/").first, 200);
  EXPECT_EQ(Get("/app/main.js").first, 200);
  EXPECT_EQ(Get("/api/events").first, 401);
  EXPECT_EQ(Get("/api/cloud").first, 401);
  EXPECT_EQ(Get("/api/trajectories").first, 401);
  auto ranged = client_->Get("/api/cloud", {{"Range", "bytes=0-5"}});  // the refusal is whole
  ASSERT_TRUE(ranged);
  EXPECT_EQ(ranged->status, 401);
  EXPECT_TRUE(IsErrorJson(ranged->body)) << ranged->body;
  httplib::Headers bearer = {{"Authorization", "Bearer viewer-query-token-0123"}};
  auto res = client_->Get("/api/trajectories", bearer);
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
}

}  // namespace
}  // namespace loci::server
