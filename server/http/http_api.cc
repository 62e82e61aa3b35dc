#include "server/http/http_api.h"

#include <optional>

#include "common/thread_name.h"
#include "proto/json.h"
#include "server/http/event_stream.h"
#include "server/http/http_reply.h"
#include "server/http/viewer_files.h"

// Last: httplib pulls <resolv.h>, whose `_res` macro breaks Eigen headers included after it.
#include <httplib.h>

namespace loci::server {
namespace {

constexpr size_t kMaxBodyBytes = 64 * 1024;
constexpr int kTimeoutS = 5;
constexpr int kKeepAliveS = 2;
constexpr int kWorkerThreads = 32;
constexpr double kDefaultCloudVoxelM = 0.05;

bool IsApiPath(const std::string& path) { return path == "/api" || path.rfind("/api/", 0) == 0; }

// cpp-httplib 0.11 (Debian bookworm) cuts every response body to a request's Range header, JSON
// answers and error replies included, and keeps their status (200 or 4xx with a Content-Range):
// `Range: bytes=0-5` turned /api/stats into `{"sess`. Only the viewer's static files honour
// Range (206); the API and every error reply ignore it, as RFC 9110 allows. Found by
// tests/fuzz/fuzz_http.cc. httplib passes its own, non-const Request to the handlers as const&.
void IgnoreRange(const httplib::Request& req) {
  const_cast<httplib::Request&>(req).ranges.clear();
}

// Optional boolean parameter `name` into *out; false (and a 400 reply) when malformed.
bool ReadBoolParam(const httplib::Request& req, httplib::Response& res, const char* name,
                   bool* out) {
  if (!req.has_param(name)) return true;
  if (ParseBool(req.get_param_value(name), out)) return true;
  SendInvalid(res, std::string(name) + " must be 0, 1, true or false");
  return false;
}

void HandleAsk(QueryApi& service, const httplib::Request& req, httplib::Response& res) {
  if (!req.has_param("q")) {
    return SendInvalid(res,
                       "missing query parameter q (the question), e.g. /api/ask?q=where+is+the+book");
  }
  loci::v1::AskRequest ask;
  ask.set_text(req.get_param_value("q"));
  ask.set_robot_name(req.get_param_value("robot"));
  loci::v1::AskResponse resp;
  SendGrpc(res, service.Ask(ask, &resp), resp);
}

void HandleObjects(QueryApi& service, const httplib::Request& req, httplib::Response& res) {
  loci::v1::FindObjectsRequest find;
  for (const std::string& c : ParamList(req, "class")) find.add_classes(c);
  if (req.has_param("min_confidence")) {
    double c = 0;
    if (!ParseDouble(req.get_param_value("min_confidence"), &c) || c < 0 || c > 1) {
      return SendInvalid(res, "min_confidence must be a number in [0, 1]");
    }
    find.set_min_confidence(c);
  }
  bool confirmed_only = false;
  if (!ReadBoolParam(req, res, "confirmed_only", &confirmed_only)) return;
  find.set_confirmed_only(confirmed_only);
  bool include_islands = false;
  if (!ReadBoolParam(req, res, "include_islands", &include_islands)) return;
  find.set_include_islands(include_islands);
  bool include_removed = false;
  if (!ReadBoolParam(req, res, "include_removed", &include_removed)) return;
  find.set_include_removed(include_removed);
  if (req.has_param("limit")) {
    uint32_t limit = 0;
    if (!ParseInt(req.get_param_value("limit"), &limit)) {
      return SendInvalid(res, "limit must be a non-negative integer");
    }
    find.set_limit(limit);
  }
  loci::v1::FindObjectsResponse resp;
  SendGrpc(res, service.FindObjects(find, &resp), resp);
}

void HandleObject(QueryApi& service, const httplib::Request& req, httplib::Response& res) {
  loci::v1::GetObjectRequest get;
  int64_t id = 0;
  if (!ParseInt(req.matches[1].str(), &id)) {
    return SendInvalid(res, "object id must be an integer, got '" + req.matches[1].str() + "'");
  }
  get.set_id(id);
  bool with_cloud = false;
  if (!ReadBoolParam(req, res, "with_cloud", &with_cloud)) return;
  get.set_with_cloud(with_cloud);
  loci::v1::GetObjectResponse resp;
  SendGrpc(res, service.GetObject(get, &resp), resp);
}

void HandleCloud(QueryApi& service, const httplib::Request& req, httplib::Response& res) {
  loci::v1::GetCloudRequest get;
  double voxel_m = kDefaultCloudVoxelM;
  if (req.has_param("voxel_m") &&
      (!ParseDouble(req.get_param_value("voxel_m"), &voxel_m) || voxel_m < 0)) {
    return SendInvalid(res, "voxel_m must be a number >= 0 (metres; 0 = the map's voxel)");
  }
  get.set_voxel_m(voxel_m);
  for (const std::string& c : ParamList(req, "class")) get.add_classes(c);
  loci::v1::GetCloudResponse resp;
  SendGrpc(res, service.GetCloud(get, &resp), resp);
}

void HandleTrajectories(QueryApi& service, const httplib::Request& req,
                        httplib::Response& res) {
  loci::v1::GetTrajectoriesRequest get;
  for (const std::string& r : ParamList(req, "robot")) get.add_robots(r);
  loci::v1::GetTrajectoriesResponse resp;
  SendGrpc(res, service.GetTrajectories(get, &resp), resp);
}

}  // namespace

StatusOr<std::unique_ptr<HttpApi>> HttpApi::Start(QueryApi* service,
                                                  const std::string& listen,
                                                  const Authorizer* auth, const TlsFiles& tls,
                                                  const HttpOptions& options) {
  const size_t colon = listen.rfind(':');
  int port = -1;
  if (colon == std::string::npos || !ParseInt(listen.substr(colon + 1), &port) || port < 0 ||
      port > 65535) {
    return absl::InvalidArgumentError("--http wants HOST:PORT or off, got '" + listen + "'");
  }
  std::unique_ptr<httplib::Server> http;
  if (tls.cert_file.empty()) {
    http = std::make_unique<httplib::Server>();
  } else {
    auto https = std::make_unique<httplib::SSLServer>(
        tls.cert_file.c_str(), tls.key_file.c_str(),
        tls.client_ca_file.empty() ? nullptr : tls.client_ca_file.c_str());
    if (!https->is_valid()) {
      return absl::InvalidArgumentError("HTTPS: cannot load the TLS certificate or key (" +
                                        tls.cert_file + ", " + tls.key_file + ")");
    }
    http = std::move(https);
  }
  LOCI_ASSIGN_OR_RETURN(std::unique_ptr<HttpApi> api,
                        Attach(std::move(http), service, auth, options));
  const std::string host = listen.substr(0, colon);
  if (port == 0) {
    api->port_ = api->http_->bind_to_any_port(host);
  } else {
    api->port_ = api->http_->bind_to_port(host, port) ? port : -1;
  }
  if (api->port_ <= 0) {
    return absl::UnavailableError("HTTP API cannot listen on " + listen);
  }
  api->thread_ = NamedThread("loci-http", [raw = api.get()] { raw->http_->listen_after_bind(); });
  return api;
}

StatusOr<std::unique_ptr<HttpApi>> HttpApi::Attach(std::unique_ptr<httplib::Server> http,
                                                   QueryApi* service,
                                                   const Authorizer* auth,
                                                   const HttpOptions& options) {
  if (!options.viewer_dir.empty() && !HasViewer(options.viewer_dir)) {
    return absl::InvalidArgumentError("no web viewer in '" + options.viewer_dir +
                                      "' (index.html missing; build the loci_viewer target)");
  }
  std::unique_ptr<HttpApi> api(new HttpApi());
  api->service_ = service;
  api->auth_ = auth;
  api->events_ = std::make_unique<EventStreams>(service, options.max_event_clients);
  api->http_ = std::move(http);
  api->Harden();
  api->Route();
  if (!options.viewer_dir.empty() && !MountViewer(*api->http_, options.viewer_dir)) {
    return absl::InvalidArgumentError("cannot serve the web viewer from " + options.viewer_dir);
  }
  return api;
}

HttpApi::~HttpApi() { Shutdown(); }

void HttpApi::Shutdown() {
  if (events_) events_->Stop();  // open event streams end, so the worker threads can join
  if (http_) http_->stop();
  if (thread_.joinable()) thread_.join();
}

void HttpApi::Harden() {
  http_->set_payload_max_length(kMaxBodyBytes);
  http_->set_read_timeout(kTimeoutS, 0);
  http_->set_write_timeout(kTimeoutS, 0);
  http_->set_idle_interval(0, 100'000);
  http_->set_keep_alive_timeout(kKeepAliveS);
  http_->new_task_queue = [] { return new httplib::ThreadPool(kWorkerThreads); };
  http_->set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
    if (!IsApiPath(req.path)) return httplib::Server::HandlerResponse::Unhandled;
    IgnoreRange(req);
    if (auth_ == nullptr || !auth_->enabled()) return httplib::Server::HandlerResponse::Unhandled;
    const std::string value = req.get_header_value("Authorization");  // owns the bytes
    std::optional<std::string_view> header;
    if (req.has_header("Authorization")) header = value;
    StatusOr<Principal> who = auth_->Authenticate(header);
    Status allowed = who.ok() ? Authorizer::AllowRead(*who) : who.status();
    if (allowed.ok()) return httplib::Server::HandlerResponse::Unhandled;
    SendError(res, allowed);
    return httplib::Server::HandlerResponse::Handled;
  });
}

void HttpApi::Route() {
  RouteMap();
  http_->Get("/api/events", [this](const httplib::Request& req, httplib::Response& res) {
    events_->Serve(req, res);
  });
  // Every error reply without a body (unknown paths, httplib's 400/413/414): a JSON body.
  http_->set_error_handler([](const httplib::Request& req, httplib::Response& res) {
    IgnoreRange(req);
    if (res.body.empty()) res.set_content(ErrorJson(StatusOfHttpError(res.status, req)), kJsonType);
  });
  http_->set_exception_handler(
      [](const httplib::Request&, httplib::Response& res, std::exception_ptr) {
        SendError(res, absl::InternalError("internal error"));
      });
}

// The request/response endpoints, each one QueryApi call.
void HttpApi::RouteMap() {
  using Handler = void (*)(QueryApi&, const httplib::Request&, httplib::Response&);
  const std::pair<const char*, Handler> routes[] = {
      {"/api/ask", HandleAsk},
      {"/api/objects", HandleObjects},
      {R"(/api/objects/([^/]+))", HandleObject},
      {"/api/cloud", HandleCloud},
      {"/api/trajectories", HandleTrajectories},
  };
  for (const auto& [pattern, handler] : routes) {
    http_->Get(pattern, [this, handler = handler](const httplib::Request& req,
                                                  httplib::Response& res) {
      handler(*service_, req, res);
    });
  }
  http_->Get("/api/stats", [this](const httplib::Request&, httplib::Response& res) {
    loci::v1::GetStatsResponse resp;
    SendGrpc(res, service_->GetStats(&resp), resp);
  });
}

}  // namespace loci::server
