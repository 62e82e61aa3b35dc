#include "server/service/grpc_server.h"

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/server_builder.h>

#include <chrono>

namespace loci::server {

StatusOr<std::unique_ptr<GrpcServer>> GrpcServer::Start(MapServer* server,
                                                        const std::string& listen,
                                                        int max_message_mb,
                                                        std::shared_ptr<QueryEngine> engine) {
  if (listen.find(':') == std::string::npos) {
    return absl::InvalidArgumentError(
        absl::StrCat("listen address '", listen, "' must be HOST:PORT"));
  }
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  std::unique_ptr<GrpcServer> g(new GrpcServer());
  g->mapping_ = std::make_unique<MappingService>(server);
  g->query_ = std::make_unique<QueryService>(server, std::move(engine));
  grpc::ServerBuilder builder;
  builder.AddListeningPort(listen, grpc::InsecureServerCredentials(), &g->port_);
  // Larger messages are refused by gRPC with RESOURCE_EXHAUSTED before reaching the handlers.
  builder.SetMaxReceiveMessageSize(max_message_mb * 1024 * 1024);
  builder.SetMaxSendMessageSize(1024 * 1024 * 1024);
  builder.RegisterService(g->mapping_.get());
  builder.RegisterService(g->query_.get());
  g->server_ = builder.BuildAndStart();
  if (!g->server_ || g->port_ == 0) {
    return absl::UnavailableError(absl::StrCat("cannot listen on ", listen));
  }
  return g;
}

void GrpcServer::Shutdown() {
  if (shut_down_) return;
  shut_down_ = true;
  server_->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(2));
}

GrpcServer::~GrpcServer() { Shutdown(); }

}  // namespace loci::server
