// Authentication, roles and TLS against the real loci-server binary on loopback. Certificates
// are made at test time with openssl (a throwaway CA, a server certificate for 127.0.0.1 and a
// client certificate); no key is committed.
#include <grpcpp/create_channel.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "loci/v1/mapping.grpc.pb.h"
#include "loci/v1/query.grpc.pb.h"
#include "proto/channel.h"
#include "tests/server/keyframe_proto.h"
#include "tests/support/server_process.h"

namespace loci {
namespace {

namespace fs = std::filesystem;

constexpr char kAdmin[] = "admin-token-0123456789";
constexpr char kQuery[] = "query-token-0123456789";
constexpr char kAlice[] = "alice-token-0123456789";

// Runs a shell command; returns its stdout (and the exit status in *rc).
std::string Shell(const std::string& cmd, int* rc = nullptr) {
  std::string out;
  FILE* p = popen(cmd.c_str(), "r");
  if (p == nullptr) return out;
  std::array<char, 4096> buf;
  while (size_t n = fread(buf.data(), 1, buf.size(), p)) out.append(buf.data(), n);
  const int status = pclose(p);
  if (rc) *rc = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return out;
}

class AuthTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(fs::temp_directory_path() / ("loci_auth_test_" + std::to_string(getpid())));
    fs::create_directories(*dir_);
    const std::string d = dir_->string();
    std::ofstream(d + "/tokens.txt") << "# test tokens\n"
                                     << kAdmin << " admin\n"
                                     << kQuery << " query   # read only\n"
                                     << kAlice << " robot:alice\n";
    std::ofstream(d + "/san.cnf") << "subjectAltName=IP:127.0.0.1,DNS:localhost\n";
    const std::string key = " -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes ";
    int rc = 0;
    Shell("cd " + d + " && openssl req -x509" + key +
            "-keyout ca.key -out ca.pem -days 1 -subj /CN=loci-test-ca 2>&1 &&"
            " openssl req" + key + "-keyout other_ca.key -out other_ca.pem -x509 -days 1"
            " -subj /CN=other-ca 2>&1 &&"
            " openssl req" + key + "-keyout server.key -out server.csr -subj /CN=localhost 2>&1 &&"
            " openssl x509 -req -in server.csr -CA ca.pem -CAkey ca.key -CAcreateserial"
            " -out server.pem -days 1 -extfile san.cnf 2>&1 &&"
            " openssl req" + key + "-keyout client.key -out client.csr -subj /CN=alice 2>&1 &&"
            " openssl x509 -req -in client.csr -CA ca.pem -CAkey ca.key -CAcreateserial"
            " -out client.pem -days 1 2>&1",
        &rc);
    ASSERT_EQ(rc, 0) << "openssl failed";
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
  }
  static std::string File(const std::string& name) { return (*dir_ / name).string(); }

  // A server with the token file; `extra` adds flags (TLS).
  std::unique_ptr<testing::ServerProcess> Start(std::vector<std::string> extra = {}) {
    extra.insert(extra.end(), {"--token-file", File("tokens.txt"), "--http", "127.0.0.1:0"});
    const std::string db = File("loci_" + std::to_string(++servers_) + ".db");
    return std::make_unique<testing::ServerProcess>(
        testing::ServerProcessOptions{.db = db, .extra_args = extra});
  }

  static std::shared_ptr<grpc::Channel> Channel(const testing::ServerProcess& s,
                                                ChannelSecurity security) {
    auto c = MakeChannel(s.address(), security);
    EXPECT_TRUE(c.ok()) << c.status();
    return *c;
  }

  static grpc::StatusCode FindObjects(const std::shared_ptr<grpc::Channel>& channel) {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
    loci::v1::FindObjectsResponse resp;
    return loci::v1::Query::NewStub(channel)
        ->FindObjects(&ctx, loci::v1::FindObjectsRequest(), &resp)
        .error_code();
  }

  static grpc::Status Open(const std::shared_ptr<grpc::Channel>& channel, const std::string& robot,
                           std::string* session_id = nullptr) {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
    loci::v1::OpenSessionResponse resp;
    const grpc::Status s = loci::v1::Mapping::NewStub(channel)->OpenSession(
        &ctx, server::testing::OpenRequest(robot, PinholeCamera::TumFr1(), false), &resp);
    if (session_id) *session_id = resp.session_id();
    return s;
  }

  // HTTP status of GET /api/stats via curl ("" token: no header).
  static std::string CurlStats(const std::string& url, const std::string& token,
                               const std::string& curl_args = "") {
    std::string cmd = "curl -s -o /dev/null -w '%{http_code}' " + curl_args;
    if (!token.empty()) cmd += " -H 'Authorization: Bearer " + token + "'";
    return Shell(cmd + " " + url + "/api/stats");
  }

  static fs::path* dir_;
  int servers_ = 0;
};

fs::path* AuthTest::dir_ = nullptr;

TEST_F(AuthTest, TokensAndRolesOnGrpcAndHttp) {
  auto server = Start();
  ASSERT_GT(server->port(), 0);
  const auto anonymous = Channel(*server, {});
  const auto query = Channel(*server, {.token = kQuery});
  const auto alice = Channel(*server, {.token = kAlice});
  const auto admin = Channel(*server, {.token = kAdmin});
  const auto stranger = Channel(*server, {.token = "not-a-token-0123456789"});

  EXPECT_EQ(FindObjects(anonymous), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(FindObjects(stranger), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(FindObjects(query), grpc::StatusCode::OK);
  EXPECT_EQ(FindObjects(admin), grpc::StatusCode::OK);
  EXPECT_EQ(FindObjects(alice), grpc::StatusCode::PERMISSION_DENIED);  // robots only write

  EXPECT_EQ(Open(query, "alice").error_code(), grpc::StatusCode::PERMISSION_DENIED);
  EXPECT_EQ(Open(alice, "bob").error_code(), grpc::StatusCode::PERMISSION_DENIED);
  std::string alice_session, bob_session;
  ASSERT_TRUE(Open(alice, "alice", &alice_session).ok());
  ASSERT_TRUE(Open(admin, "bob", &bob_session).ok());
  EXPECT_NE(alice_session.find("alice-"), std::string::npos);

  // alice may not write to or close bob's session, even knowing its id.
  grpc::ClientContext ctx;
  auto stream = loci::v1::Mapping::NewStub(alice)->StreamKeyframes(&ctx);
  const cv::Mat bgr(480, 640, CV_8UC3, cv::Scalar(90, 120, 150));
  const cv::Mat depth(480, 640, CV_16UC1, cv::Scalar(5000));
  const int64_t t_ns = 1'700'000'000'000'000'000;
  ASSERT_TRUE(stream->Write(
      server::testing::MakeKeyframe(bob_session, 0, t_ns, SE3d::Identity(), bgr, depth, {})));
  loci::v1::KeyframeAck ack;
  ASSERT_TRUE(stream->Read(&ack));
  EXPECT_EQ(ack.status().code(), static_cast<int>(grpc::StatusCode::PERMISSION_DENIED));
  ASSERT_TRUE(stream->Write(
      server::testing::MakeKeyframe(alice_session, 0, t_ns, SE3d::Identity(), bgr, depth, {})));
  ASSERT_TRUE(stream->Read(&ack));
  EXPECT_EQ(ack.status().code(), 0) << ack.status().message();
  stream->WritesDone();
  EXPECT_TRUE(stream->Finish().ok());
  grpc::ClientContext close_ctx;
  loci::v1::CloseSessionRequest close;
  close.set_session_id(bob_session);
  loci::v1::CloseSessionResponse closed;
  EXPECT_EQ(loci::v1::Mapping::NewStub(alice)->CloseSession(&close_ctx, close, &closed).error_code(),
            grpc::StatusCode::PERMISSION_DENIED);

  const std::string http = "http://127.0.0.1:" + std::to_string(server->http_port());
  EXPECT_EQ(CurlStats(http, ""), "401");
  EXPECT_EQ(CurlStats(http, kAlice), "403");
  EXPECT_EQ(CurlStats(http, kQuery), "200");
  // Errors carry a JSON body, httplib's own ones included.
  EXPECT_NE(Shell("curl -s -H 'Authorization: Bearer " + std::string(kQuery) + "' " + http +
                "/api/nothing").find("\"NOT_FOUND\""),
            std::string::npos);
  EXPECT_NE(Shell("curl -s " + http + "/api/stats").find("\"UNAUTHENTICATED\""), std::string::npos);
  // A 4 MB body is refused from its length (limit 64 KiB), with a JSON error.
  const std::string big = Shell("head -c 4000000 /dev/zero | curl -s -w ' %{http_code}' "
                                "-H 'Authorization: Bearer " + std::string(kQuery) +
                                "' --data-binary @- " + http + "/api/stats");
  EXPECT_NE(big.find(" 413"), std::string::npos) << big;
  EXPECT_NE(big.find("\"error\""), std::string::npos) << big;
}

TEST_F(AuthTest, TlsAndMutualTls) {
  auto server = Start({"--tls-cert", File("server.pem"), "--tls-key", File("server.key")});
  ASSERT_GT(server->port(), 0);
  ASSERT_TRUE(server->WaitServing({.token = kQuery, .tls_ca_file = File("ca.pem")}).ok());
  EXPECT_EQ(FindObjects(Channel(*server, {.token = kQuery, .tls_ca_file = File("ca.pem")})),
            grpc::StatusCode::OK);
  // A client that does not trust the server's CA, or speaks plaintext, gets nowhere.
  EXPECT_EQ(FindObjects(Channel(*server, {.token = kQuery, .tls_ca_file = File("other_ca.pem")})),
            grpc::StatusCode::UNAVAILABLE);
  EXPECT_EQ(FindObjects(Channel(*server, {.token = kQuery})), grpc::StatusCode::UNAVAILABLE);
  const std::string https = "https://127.0.0.1:" + std::to_string(server->http_port());
  EXPECT_EQ(CurlStats(https, kQuery, "--cacert " + File("ca.pem")), "200");
  EXPECT_EQ(CurlStats(https, kQuery, "--cacert " + File("other_ca.pem")), "000");
  server.reset();

  auto mutual = Start({"--tls-cert", File("server.pem"), "--tls-key", File("server.key"),
                       "--tls-client-ca", File("ca.pem")});
  ASSERT_GT(mutual->port(), 0);
  ASSERT_TRUE(mutual->WaitServing({.token = kQuery,
                                   .tls_ca_file = File("ca.pem"),
                                   .tls_cert_file = File("client.pem"),
                                   .tls_key_file = File("client.key")})
                  .ok());
  EXPECT_EQ(FindObjects(Channel(*mutual, {.token = kQuery, .tls_ca_file = File("ca.pem")})),
            grpc::StatusCode::UNAVAILABLE);  // no client certificate
  EXPECT_EQ(FindObjects(Channel(*mutual, {.token = kQuery,
                                          .tls_ca_file = File("ca.pem"),
                                          .tls_cert_file = File("client.pem"),
                                          .tls_key_file = File("client.key")})),
            grpc::StatusCode::OK);
}

TEST_F(AuthTest, NonLoopbackWithoutTokensIsRefused) {
  const std::string err = File("exposed.err");
  testing::ServerProcess exposed(testing::ServerProcessOptions{
      .db = File("exposed.db"), .listen = "0.0.0.0:0", .stderr_path = err});
  EXPECT_EQ(exposed.port(), 0);
  const int status = exposed.Stop(0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 2) << status;
  std::ifstream in(err);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("without authentication"), std::string::npos) << text;
  EXPECT_FALSE(fs::exists(File("exposed.db")));  // refused before anything was created
}

}  // namespace
}  // namespace loci
