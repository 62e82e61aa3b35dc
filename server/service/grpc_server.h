// Runs the Mapping and Query services on one gRPC server with the health service (NOT_SERVING
// until the map is loaded, then SERVING) and reflection enabled and an explicit maximum message
// size.
#pragma once

#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/server.h>

#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "common/status.h"
#include "server/service/read_only_services.h"
#include "server/service/services.h"

namespace loci::server {

class GrpcServer {
 public:
  // Binds `listen` (HOST:PORT, port 0 = any free port) and starts serving `server`; `engine`
  // answers Ask (null: Ask is UNIMPLEMENTED). Calls are checked against `auth` (auth.h; default:
  // no tokens, everyone is admin).
  static StatusOr<std::unique_ptr<GrpcServer>> Start(MapServer* server, const std::string& listen,
                                                     int max_message_mb,
                                                     std::shared_ptr<QueryEngine> engine = nullptr,
                                                     Authorizer auth = {}, const TlsFiles& tls = {});
  // A read-only query server over the map a site's writer publishes (read_only_services.h);
  // `writer` tells robots and callers of writer-only calls where to go instead. Health is
  // SERVING once the first publication is loaded.
  static StatusOr<std::unique_ptr<GrpcServer>> StartReadOnly(
      ReplicaMap* map, MapStore* store, const std::string& listen, int max_message_mb,
      std::shared_ptr<QueryAdapter> engine, WriterAddress writer, Authorizer auth = {},
      const TlsFiles& tls = {});
  ~GrpcServer();

  int port() const { return port_; }
  // The Query service's calls for the HTTP API: the mapping server's or the read-only one's.
  QueryApi* query_service() { return query_; }
  const Authorizer& auth() const { return auth_; }
  // Stops accepting calls and ends the running ones (deadline 2 s).
  void Shutdown();
  void Wait() { server_->Wait(); }

 private:
  GrpcServer() = default;
  // Binds `listen` and serves services_.
  Status Serve(const std::string& listen, int max_message_mb, const TlsFiles& tls);
  // The gRPC health service answers NOT_SERVING until the map is loaded: `on_ready` runs its
  // function then.
  void ReportHealth(const std::function<void(std::function<void()>)>& on_ready);
  struct HealthHook {
    std::mutex mu;
    grpc::HealthCheckServiceInterface* service = nullptr;  // null once shut down
  };
  std::shared_ptr<HealthHook> health_;
  Authorizer auth_;
  std::vector<std::unique_ptr<grpc::Service>> services_;
  QueryApi* query_ = nullptr;  // in services_
  std::unique_ptr<grpc::Server> server_;
  int port_ = 0;
  bool shut_down_ = false;
};

}  // namespace loci::server
