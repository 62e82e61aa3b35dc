// Shared by the commands that call a running loci-server's Query service (`loci ask`,
// `loci objects`, `loci stats`): their options, connection, deadline, one call and the report of
// a failed call.
#pragma once

#include <grpcpp/client_context.h>

#include <memory>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>

#include "common/status.h"
#include "loci/v1/query.grpc.pb.h"
#include "proto/channel.h"

namespace loci::cli {

// --token and --tls-ca ($LOCI_TOKEN and $LOCI_TLS_CA when not given).
void AddSecurityOptions(CLI::App* c, ChannelSecurity* security);
// A Query stub for `server` (TLS files unreadable: the error).
StatusOr<std::unique_ptr<loci::v1::Query::Stub>> ConnectQuery(
    const std::string& server, const ChannelSecurity& security,
    const grpc::ChannelArguments& args = grpc::ChannelArguments());
void SetDeadline(grpc::ClientContext* ctx, double timeout_s);
// Prints "error: ..." on stderr and returns 2 (no channel: unreadable TLS files, a bad address).
int ReportNoChannel(const Status& status);
// Prints the message as proto JSON on stdout and returns 0.
int PrintJson(const google::protobuf::Message& message);
// Reports a failed call and returns the exit code (1). With `json`, stdout gets the error as
// {"error":{"code":"INVALID_ARGUMENT","message":"..."}} (as the HTTP API), else stderr a line.
int ReportFailure(const std::string& server, const grpc::Status& s, bool json);

// What every command that calls the server takes: --server, --json, --timeout and the
// security options.
struct ServerArgs {
  std::string server = "127.0.0.1:50051";
  bool json = false;
  double timeout_s = 10.0;
  ChannelSecurity security;
};
void AddServerOptions(CLI::App* c, ServerArgs* a);

// Calls one Query RPC (`rpc`, e.g. &loci::v1::Query::Stub::Ask) on a.server within a.timeout_s.
// Returns the command's exit code when it is done: 2 when there is no channel, 1 when the call
// failed (ReportFailure), 0 when a.json printed the response as proto JSON. Returns nullopt when
// the call succeeded and the caller prints *resp as text.
template <class Request, class Response>
std::optional<int> CallQuery(const ServerArgs& a,
                             grpc::Status (loci::v1::Query::Stub::*rpc)(grpc::ClientContext*,
                                                                        const Request&, Response*),
                             const Request& req, Response* resp) {
  auto stub = ConnectQuery(a.server, a.security);
  if (!stub.ok()) return ReportNoChannel(stub.status());
  grpc::ClientContext ctx;
  SetDeadline(&ctx, a.timeout_s);
  const grpc::Status s = ((**stub).*rpc)(&ctx, req, resp);
  if (!s.ok()) return ReportFailure(a.server, s, a.json);
  if (a.json) return PrintJson(*resp);
  return std::nullopt;
}

}  // namespace loci::cli
