// JSON over HTTP for the Query service (cpp-httplib), on its own port next to gRPC, and the web
// viewer. Every /api endpoint calls the same QueryApi method as gRPC and prints its response
// message with the proto3 JSON mapping (proto/json.h), so HTTP and gRPC answers agree.
//
//   GET /api/ask?q=QUESTION[&robot=NAME]   AskResponse (400 for a question it cannot take)
//   GET /api/objects[?class=C[,C2]&min_confidence=X&confirmed_only=1&limit=N]
//                                          FindObjectsResponse
//   GET /api/objects/{id}[?with_cloud=1]   GetObjectResponse (404 when unknown)
//   GET /api/stats                         GetStatsResponse
//   GET /api/cloud[?voxel_m=X&class=C[,C2]] GetCloudResponse: the semantic cloud downsampled to
//                                          voxel_m metres (default 0.05; 0 = the map's voxel),
//                                          each point with rgb and object id (0 = background)
//   GET /api/trajectories[?robot=R[,R2]]   GetTrajectoriesResponse: each robot's keyframe poses
//                                          T_map_cam in time order (the last is its latest pose)
//   GET /api/events                        Server-Sent Events: `event: ready` once subscribed,
//                                          then `event: object` with an ObjectEvent (WatchObjects)
//                                          per change; 503 beyond server.max_event_clients
//                                          streams (event_stream.h)
//   GET /, /index.html, /app/*.js ...      the web viewer (viewer/, served read-only from
//                                          HttpOptions::viewer_dir; viewer_files.h)
// Errors: the gRPC status as {"error":{"code":"INVALID_ARGUMENT","message":"..."}} (code names
// from absl::StatusCodeToString) with HTTP 400 / 401 / 403 / 404 / 409 / 500 / 501 / 503; every
// other error reply (404 unknown path, 413 payload too large, 414 URI too long ...) carries the
// same JSON body. With tokens (auth.h), /api requests need `Authorization: Bearer TOKEN` of a
// role that may read; the viewer's static files hold no map data and are served without.
// A Range header is honoured by the viewer's files only (206); JSON answers and error replies
// are always whole. Limits: bodies over 64 KiB are refused, reads and writes time out after 5 s,
// idle keep-alive connections close after 2 s, and 32 worker threads serve connections (event
// streams hold one each while open).
#pragma once

#include <memory>
#include <string>
#include <thread>

#include "common/status.h"
#include "server/service/auth.h"
#include "server/service/query_api.h"

namespace httplib {
class Server;
}

namespace loci::server {

class EventStreams;

struct HttpOptions {
  std::string viewer_dir;     // static viewer files served at "/"; "" = no viewer
  int max_event_clients = 8;  // /api/events streams at once (server.max_event_clients)
};

class HttpApi {
 public:
  // Binds `listen` (HOST:PORT, port 0 = any free port) and serves on a background thread;
  // HTTPS when tls.cert_file is set. `auth` (default: no tokens) outlives the API.
  // INVALID_ARGUMENT when options.viewer_dir is set but holds no index.html.
  static StatusOr<std::unique_ptr<HttpApi>> Start(QueryApi* service, const std::string& listen,
                                                  const Authorizer* auth = nullptr,
                                                  const TlsFiles& tls = {},
                                                  const HttpOptions& options = {});
  // The same API (routes, limits, auth, viewer) on a server the caller drives itself: nothing
  // is bound and no thread runs. For in-process drivers that hand request bytes to httplib's
  // request processing (tests/fuzz/fuzz_http.cc); Start() is Attach plus a listening socket.
  static StatusOr<std::unique_ptr<HttpApi>> Attach(std::unique_ptr<httplib::Server> http,
                                                   QueryApi* service,
                                                   const Authorizer* auth = nullptr,
                                                   const HttpOptions& options = {});
  ~HttpApi();  // stops serving
  HttpApi(const HttpApi&) = delete;
  HttpApi& operator=(const HttpApi&) = delete;

  int port() const { return port_; }
  void Shutdown();

 private:
  HttpApi() = default;
  void Route();
  void RouteMap();
  void Harden();

  QueryApi* service_ = nullptr;
  const Authorizer* auth_ = nullptr;
  std::unique_ptr<EventStreams> events_;  // outlives http_ (declared first)
  std::unique_ptr<httplib::Server> http_;
  std::thread thread_;
  int port_ = 0;
};

}  // namespace loci::server
