// JSON over HTTP for the Query service (cpp-httplib), on its own port next to gRPC. Every
// endpoint calls the same QueryService method as gRPC and prints its response message with the
// proto3 JSON mapping (proto/json.h), so HTTP and gRPC answers agree.
//
//   GET /api/ask?q=QUESTION[&robot=NAME]   AskResponse (400 for a question it cannot take)
//   GET /api/objects[?class=C[,C2]&min_confidence=X&confirmed_only=1&limit=N]
//                                          FindObjectsResponse
//   GET /api/objects/{id}[?with_cloud=1]   GetObjectResponse (404 when unknown)
//   GET /api/stats                         GetStatsResponse
// Errors: the gRPC status as {"error":{"code":"INVALID_ARGUMENT","message":"..."}} (code names
// from absl::StatusCodeToString) with HTTP 400 / 401 / 403 / 404 / 409 / 500 / 501 / 503; every
// other error reply (413 payload too large, 414 URI too long ...) carries the same JSON body.
// With tokens (auth.h), requests need `Authorization: Bearer TOKEN` of a role that may read.
// Limits: bodies over 64 KiB are refused, reads and writes time out after 5 s, idle keep-alive
// connections close after 2 s, and 32 worker threads serve connections.
#pragma once

#include <memory>
#include <string>
#include <thread>

#include "common/status.h"
#include "server/service/services.h"

namespace httplib {
class Server;
}

namespace loci::server {

class HttpApi {
 public:
  // Binds `listen` (HOST:PORT, port 0 = any free port) and serves on a background thread;
  // HTTPS when tls.cert_file is set. `auth` (default: no tokens) outlives the API.
  static StatusOr<std::unique_ptr<HttpApi>> Start(QueryService* service, const std::string& listen,
                                                  const Authorizer* auth = nullptr,
                                                  const TlsFiles& tls = {});
  ~HttpApi();  // stops serving
  HttpApi(const HttpApi&) = delete;
  HttpApi& operator=(const HttpApi&) = delete;

  int port() const { return port_; }
  void Shutdown();

 private:
  HttpApi() = default;
  void Route();
  void Harden();

  QueryService* service_ = nullptr;
  const Authorizer* auth_ = nullptr;
  std::unique_ptr<httplib::Server> http_;
  std::thread thread_;
  int port_ = 0;
};

}  // namespace loci::server
