#include "server/service/grpc_server.h"

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/server_builder.h>

#include <chrono>

#include "common/image_codec.h"  // ReadFileBytes

namespace loci::server {
namespace {

StatusOr<std::shared_ptr<grpc::ServerCredentials>> ServerCredentials(const TlsFiles& tls) {
  if (tls.cert_file.empty()) return grpc::InsecureServerCredentials();
  grpc::SslServerCredentialsOptions ssl;
  grpc::SslServerCredentialsOptions::PemKeyCertPair pair;
  LOCI_ASSIGN_OR_RETURN(pair.cert_chain, ReadFileBytes(tls.cert_file));
  LOCI_ASSIGN_OR_RETURN(pair.private_key, ReadFileBytes(tls.key_file));
  ssl.pem_key_cert_pairs.push_back(std::move(pair));
  if (!tls.client_ca_file.empty()) {
    LOCI_ASSIGN_OR_RETURN(ssl.pem_root_certs, ReadFileBytes(tls.client_ca_file));
    ssl.client_certificate_request = GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY;
  }
  return grpc::SslServerCredentials(ssl);
}

}  // namespace

StatusOr<std::unique_ptr<GrpcServer>> GrpcServer::Start(MapServer* server,
                                                        const std::string& listen,
                                                        int max_message_mb,
                                                        std::shared_ptr<QueryEngine> engine,
                                                        Authorizer auth, const TlsFiles& tls) {
  std::unique_ptr<GrpcServer> g(new GrpcServer());
  g->auth_ = std::move(auth);
  g->services_.push_back(std::make_unique<MappingService>(server, &g->auth_));
  auto query = std::make_unique<QueryService>(server, std::move(engine), &g->auth_);
  g->query_ = query.get();
  g->services_.push_back(std::move(query));
  LOCI_RETURN_IF_ERROR(g->Serve(listen, max_message_mb, tls));
  g->ReportHealth([server](std::function<void()> fn) { server->readiness().OnReady(std::move(fn)); });
  return g;
}

StatusOr<std::unique_ptr<GrpcServer>> GrpcServer::StartReadOnly(
    ReplicaMap* map, MapStore* store, const std::string& listen, int max_message_mb,
    std::shared_ptr<QueryAdapter> engine, WriterAddress writer, Authorizer auth,
    const TlsFiles& tls) {
  std::unique_ptr<GrpcServer> g(new GrpcServer());
  g->auth_ = std::move(auth);
  g->services_.push_back(std::make_unique<ReadOnlyMappingService>(map->site(), writer));
  auto query = std::make_unique<ReadOnlyQueryService>(map, std::move(engine), &g->auth_,
                                                      std::move(writer), store);
  g->query_ = query.get();
  g->services_.push_back(std::move(query));
  LOCI_RETURN_IF_ERROR(g->Serve(listen, max_message_mb, tls));
  g->ReportHealth([map](std::function<void()> fn) { map->readiness().OnReady(std::move(fn)); });
  return g;
}

Status GrpcServer::Serve(const std::string& listen, int max_message_mb, const TlsFiles& tls) {
  if (listen.find(':') == std::string::npos) {
    return absl::InvalidArgumentError(
        absl::StrCat("listen address '", listen, "' must be HOST:PORT"));
  }
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  LOCI_ASSIGN_OR_RETURN(std::shared_ptr<grpc::ServerCredentials> credentials,
                        ServerCredentials(tls));
  grpc::ServerBuilder builder;
  builder.AddListeningPort(listen, credentials, &port_);
  // Larger messages are refused by gRPC with RESOURCE_EXHAUSTED before reaching the handlers.
  builder.SetMaxReceiveMessageSize(max_message_mb * 1024 * 1024);
  builder.SetMaxSendMessageSize(1024 * 1024 * 1024);
  for (const auto& service : services_) builder.RegisterService(service.get());
  server_ = builder.BuildAndStart();
  if (!server_ || port_ == 0) {
    return absl::UnavailableError(absl::StrCat("cannot listen on ", listen));
  }
  return absl::OkStatus();
}

void GrpcServer::ReportHealth(const std::function<void(std::function<void()>)>& on_ready) {
  health_ = std::make_shared<HealthHook>();
  health_->service = server_->GetHealthCheckService();
  if (health_->service == nullptr) return;
  // NOT_SERVING while the map loads; the port is open, so clients wait instead of failing.
  health_->service->SetServingStatus(false);
  on_ready([hook = health_] {
    std::lock_guard<std::mutex> lock(hook->mu);
    if (hook->service != nullptr) hook->service->SetServingStatus(true);
  });
}

void GrpcServer::Shutdown() {
  if (shut_down_) return;
  shut_down_ = true;
  if (health_) {
    std::lock_guard<std::mutex> lock(health_->mu);
    health_->service = nullptr;  // the loader may finish after this server is gone
  }
  server_->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(2));
}

GrpcServer::~GrpcServer() { Shutdown(); }

}  // namespace loci::server
