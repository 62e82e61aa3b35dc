#include "cli/query_client.h"

#include <chrono>
#include <cstdio>

#include "proto/json.h"

namespace loci::cli {

void AddSecurityOptions(CLI::App* c, ChannelSecurity* security) {
  c->add_option("--token", security->token, "bearer token (default: $LOCI_TOKEN)");
  c->add_option("--tls-ca", security->tls_ca_file,
                "CA certificate (PEM) of a TLS server (default: $LOCI_TLS_CA; none: plaintext)");
}

StatusOr<std::unique_ptr<loci::v1::Query::Stub>> ConnectQuery(const std::string& server,
                                                              const ChannelSecurity& security,
                                                              const grpc::ChannelArguments& args) {
  LOCI_ASSIGN_OR_RETURN(std::shared_ptr<grpc::Channel> channel,
                        MakeChannel(server, security.WithEnvironment(), args));
  return loci::v1::Query::NewStub(channel);
}

void SetDeadline(grpc::ClientContext* ctx, double timeout_s) {
  ctx->set_deadline(std::chrono::system_clock::now() +
                    std::chrono::milliseconds(static_cast<int64_t>(timeout_s * 1e3)));
}

int ReportNoChannel(const Status& status) {
  std::fprintf(stderr, "error: %s\n", std::string(status.message()).c_str());
  return 2;
}

int PrintJson(const google::protobuf::Message& message) {
  std::printf("%s\n", ProtoToJson(message).c_str());
  return 0;
}

int ReportFailure(const std::string& server, const grpc::Status& s, bool json) {
  if (json) {
    const absl::Status status(static_cast<absl::StatusCode>(s.error_code()), s.error_message());
    std::printf("%s\n", ErrorJson(status).c_str());
  } else if (s.error_code() == grpc::StatusCode::UNAVAILABLE ||
             s.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED) {
    std::fprintf(stderr, "error: cannot reach loci-server at %s: %s\n", server.c_str(),
                 s.error_message().c_str());
  } else {
    std::fprintf(stderr, "error: %s\n", s.error_message().c_str());
  }
  return 1;
}

void AddServerOptions(CLI::App* c, ServerArgs* a) {
  c->add_option("--server", a->server, "gRPC address HOST:PORT")->capture_default_str();
  c->add_flag("--json", a->json, "print the response as proto JSON");
  c->add_option("--timeout", a->timeout_s, "seconds to wait")->capture_default_str();
  AddSecurityOptions(c, &a->security);
}

}  // namespace loci::cli
