// libFuzzer target: the JSON/HTTP API as loci-server serves it. A real HttpApi (routes, limits,
// auth, error handler, the web viewer's files) is attached to an httplib::Server that is fed
// the fuzz input as the bytes of one connection, through httplib's own request processing
// (parser, pre-routing auth check, routing, error handler, response writer); no socket, no
// thread. The QueryService behind it reads a MapServer holding a small mapped box world
// (6 keyframes, 320 x 240 px, two confirmed objects, coarse clouds) and answers Ask with the
// real query adapter.
//
// Input: byte 0 picks the server (even: no tokens, odd: a token file with a `query` token
// "fuzz-query-token" and a robot token "fuzz-robot-token"); the rest is the raw request.
// Every response must be well-formed, else the harness aborts:
//   - an HTTP/1.1 status line with a code in 100..599, header lines, a blank line, and a body of
//     Content-Length bytes (gzip or brotli bodies are decoded first);
//   - every 4xx/5xx carries Content-Type application/json and {"error":{"code","message"}};
//   - every 2xx JSON body parses as a JSON object other than the bare {} that ProtoToJson gives
//     when it cannot print, and no response leaks the file beside the viewer folder.
// LOCI_FUZZ_VERBOSE=1 prints each response (its first 600 bytes).
#include <google/protobuf/stubs/logging.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

#include "common/image_codec.h"
#include "proto/convert.h"
#include "server/http/http_api.h"
#include "server/http/http_reply.h"
#include "server/runtime/map_server.h"
#include "server/service/query_adapter.h"
#include "tests/server/box_world.h"

// Last: httplib pulls <resolv.h>, whose `_res` macro breaks Eigen headers included after it.
#include <httplib.h>

namespace {

namespace fs = std::filesystem;
using loci::server::HttpApi;

constexpr std::string_view kSecret = "loci-fuzz-secret-outside-the-viewer";

[[noreturn]] void Fail(const char* what, const std::string& response) {
  std::fprintf(stderr, "fuzz_http: malformed response (%s):\n%s\n", what,
               response.substr(0, 2000).c_str());
  std::abort();
}

// One connection's bytes: reads come from the input, writes are collected.
class InputStream : public httplib::Stream {
 public:
  explicit InputStream(std::string_view in) : in_(in) {}
  bool is_readable() const override { return true; }
  bool is_writable() const override { return true; }
  ssize_t read(char* ptr, size_t size) override {
    size = std::min(size, in_.size() - pos_);
    std::copy_n(in_.data() + pos_, size, ptr);
    pos_ += size;
    return static_cast<ssize_t>(size);
  }
  ssize_t write(const char* ptr, size_t size) override {
    out_.append(ptr, size);
    return static_cast<ssize_t>(size);
  }
  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    ip = "127.0.0.1";
    port = 40000;
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    ip = "127.0.0.1";
    port = 8080;
  }
  socket_t socket() const override { return INVALID_SOCKET; }
  const std::string& written() const { return out_; }

 private:
  std::string_view in_;
  size_t pos_ = 0;
  std::string out_;
};

// httplib's request processing (protected in httplib::Server) for one request of a connection.
class InProcessServer : public httplib::Server {
 public:
  std::string Process(std::string_view request) {
    InputStream stream(request);
    bool connection_closed = false;
    process_request(stream, /*close_connection=*/true, connection_closed, nullptr);
    return stream.written();
  }
};

struct ServedApi {
  InProcessServer* http = nullptr;  // owned by api
  std::unique_ptr<HttpApi> api;
};

struct Fixture {
  fs::path dir;
  std::unique_ptr<loci::server::MapServer> map;
  loci::server::Authorizer no_tokens, tokens;
  std::unique_ptr<loci::server::QueryService> query;
  ServedApi open, guarded;
};

void WriteFile(const fs::path& path, std::string_view text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path) << text;
}

// Six keyframes of the box world (book, cup, laptop) mapped at 160 x 120 px.
void MapBoxWorld(loci::server::MapServer& map) {
  const loci::PinholeCamera camera{517.3 / 2, 516.5 / 2, 318.6 / 2, 255.3 / 2, 320, 240};
  loci::v1::OpenSessionRequest open;
  open.set_robot_name("robot1");
  loci::ToProto(camera, open.mutable_intrinsics());
  open.set_depth_scale(5000.0);
  auto session = map.OpenSession(open);
  if (!session.ok()) Fail("cannot open the fixture session", session.status().ToString());
  const auto boxes = loci::server::testing::DefaultBoxes(false);
  const auto poses = loci::server::testing::ArcPoses(6);
  for (size_t i = 0; i < poses.size(); ++i) {
    const auto view = loci::server::testing::Render(boxes, camera, poses[i], true);
    loci::v1::Keyframe kf;
    kf.set_session_id(session->session_id());
    kf.set_seq(static_cast<int64_t>(i));
    kf.set_t_ns(1'700'000'000'000'000'000 + 1'000'000'000LL * static_cast<int64_t>(i + 1));
    loci::ToProto(poses[i], kf.mutable_t_odom_cam());
    kf.set_rgb_jpeg(*loci::EncodeJpeg(view.bgr, 90));
    kf.set_depth_png(*loci::EncodeDepthPng(view.depth_u16));
    kf.set_has_gravity(true);
    loci::ToProto(poses[i].rotation().transpose() * Eigen::Vector3d(0, 0, -1),
                  kf.mutable_gravity_cam());
    for (const loci::Detection2D& d : view.detections) {
      if (!loci::ToProto(d, kf.add_detections()).ok()) Fail("fixture detection", d.class_name);
    }
    const auto ack = map.Ingest(kf);
    if (ack.status().code() != 0) Fail("fixture keyframe refused", ack.status().message());
  }
  map.Flush();
}

ServedApi Serve(Fixture& f, const loci::server::Authorizer* auth) {
  ServedApi s;
  auto http = std::make_unique<InProcessServer>();
  s.http = http.get();
  loci::server::HttpOptions options;
  options.viewer_dir = (f.dir / "viewer").string();
  // /api/events streams until the client leaves, which one synchronous request cannot do; with
  // no free slot every event request takes the 503 path.
  options.max_event_clients = 0;
  auto api = HttpApi::Attach(std::move(http), f.query.get(), auth, options);
  if (!api.ok()) Fail("cannot attach the HTTP API", api.status().ToString());
  s.api = std::move(*api);
  return s;
}

Fixture* MakeFixture() {
  auto* f = new Fixture();
  f->dir = fs::temp_directory_path() / ("loci_fuzz_http_" + std::to_string(getpid()));
  fs::remove_all(f->dir);
  WriteFile(f->dir / "viewer/index.html", "<!doctype html><title>loci</title>");
  WriteFile(f->dir / "viewer/app/main.js", "export const answer = 42;\n");
  WriteFile(f->dir / "secret.txt", kSecret);
  WriteFile(f->dir / "tokens.txt", "fuzz-query-token query\nfuzz-robot-token robot:robot1\n");
  auto tokens = loci::server::Authorizer::FromFile((f->dir / "tokens.txt").string());
  if (!tokens.ok()) Fail("token file", tokens.status().ToString());
  f->tokens = std::move(*tokens);
  loci::server::ServerOptions o;
  o.db_path = (f->dir / "map.db").string();
  o.map.mapped_classes = {"book", "cup", "laptop"};
  // Coarse clouds keep whole-map replies small: each request costs well under a millisecond.
  o.map.cloud.voxel_m = 0.1;
  o.map.observation.voxel_m = 0.03;
  auto map = loci::server::MapServer::Open(o);
  if (!map.ok()) Fail("cannot open the map", map.status().ToString());
  f->map = std::move(*map);
  MapBoxWorld(*f->map);
  f->query = std::make_unique<loci::server::QueryService>(
      f->map.get(), std::make_shared<loci::server::QueryAdapter>(loci::server::QueryAdapterOptions{}),
      &f->no_tokens);
  f->open = Serve(*f, &f->no_tokens);
  f->guarded = Serve(*f, &f->tokens);
  loci::v1::GetStatsResponse stats;
  f->query->GetStats(&stats);
  std::fprintf(stderr, "fuzz_http: fixture map with %s\n", stats.ShortDebugString().c_str());
  static fs::path dir = f->dir;  // the map stays open: removed, not closed, at exit
  std::atexit([] {
    std::error_code ec;
    fs::remove_all(dir, ec);
  });
  return f;
}

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string Decompress(const std::string& encoding, const std::string& body,
                       const std::string& response) {
  std::unique_ptr<httplib::detail::decompressor> d;
  if (encoding == "gzip") d = std::make_unique<httplib::detail::gzip_decompressor>();
  if (encoding == "br") d = std::make_unique<httplib::detail::brotli_decompressor>();
  if (!d) Fail("unknown Content-Encoding", response);
  std::string out;
  const bool ok = d->decompress(body.data(), body.size(), [&](const char* p, size_t n) {
    out.append(p, n);
    return true;
  });
  if (!ok) Fail("body does not decompress", response);
  return out;
}

// Checks the response to `request`; `head` when it was HEAD (headers only).
void CheckResponse(std::string_view request, const std::string& response, bool head) {
  size_t pos = 0;
  int status = 0;
  httplib::Headers headers;
  do {  // interim 1xx responses (100 Continue) come first
    const size_t eol = response.find("\r\n", pos);
    if (eol == std::string::npos) Fail("no status line", response);
    const std::string line = response.substr(pos, eol - pos);
    if (line.size() < 12 || line.compare(0, 9, "HTTP/1.1 ") != 0 || line[12] != ' ') {
      Fail("bad status line", response);
    }
    status = std::atoi(line.substr(9, 3).c_str());
    if (status < 100 || status > 599) Fail("status code outside 100..599", response);
    headers.clear();
    pos = eol + 2;
    for (;;) {
      const size_t end = response.find("\r\n", pos);
      if (end == std::string::npos) Fail("headers do not end", response);
      if (end == pos) break;
      const std::string h = response.substr(pos, end - pos);
      const size_t colon = h.find(": ");
      if (colon == std::string::npos || colon == 0) Fail("bad header line", response);
      headers.emplace(h.substr(0, colon), h.substr(colon + 2));
      pos = end + 2;
    }
    pos += 2;
  } while (status < 200);
  auto header = [&](const char* name) {
    auto it = headers.find(name);
    return it == headers.end() ? std::string() : it->second;
  };
  const std::string type = Lower(header("Content-Type"));
  const bool json_type = type.rfind("application/json", 0) == 0;
  if (status >= 400 && !json_type) Fail("error reply is not application/json", response);
  if (head) return;
  if (header("Transfer-Encoding").size() > 0) Fail("unexpected streamed reply", response);
  const std::string length = header("Content-Length");
  if (length.empty() && status >= 400) Fail("error reply without Content-Length", response);
  std::string body = response.substr(pos);
  if (!length.empty()) {
    size_t n = 0;
    if (!loci::server::ParseInt(length, &n) || n != body.size()) {
      Fail("Content-Length differs from the body", response);
    }
  }
  if (body.find(kSecret) != std::string::npos && request.find(kSecret) == std::string::npos) {
    Fail("file outside the viewer served", response);  // not just an echo of the request
  }
  if (const std::string enc = header("Content-Encoding"); !enc.empty()) {
    body = Decompress(enc, body, response);
  }
  if (!json_type) return;
  const nlohmann::json j = nlohmann::json::parse(body, nullptr, /*allow_exceptions=*/false);
  if (!j.is_object()) Fail("JSON body is not an object", response);
  if (status < 300 && j.empty()) Fail("bare {}: ProtoToJson could not print the answer", response);
  if (status >= 400) {
    const auto e = j.find("error");
    if (e == j.end() || !e->is_object() || !e->contains("code") || !(*e)["code"].is_string() ||
        (*e)["code"].get<std::string>().empty() || !e->contains("message") ||
        !(*e)["message"].is_string()) {
      Fail("error reply without error.code and error.message", response);
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  google::protobuf::SetLogHandler(nullptr);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static Fixture* f = MakeFixture();
  if (size == 0) return 0;
  const ServedApi& s = (data[0] & 1) ? f->guarded : f->open;
  const std::string_view request(reinterpret_cast<const char*>(data) + 1, size - 1);
  const std::string response = s.http->Process(request);
  static const bool verbose = std::getenv("LOCI_FUZZ_VERBOSE") != nullptr;
  if (verbose) std::fprintf(stderr, "fuzz_http: response:\n%s\n", response.substr(0, 600).c_str());
  if (response.empty()) return 0;  // httplib closes a connection whose request line never ends
  // A HEAD reply has no body; httplib takes the method from the request line's first word even
  // when the line is malformed (400).
  const std::string_view method = request.substr(0, request.find_first_of(" \r\n"));
  CheckResponse(request, response, method == "HEAD");
  return 0;
}
