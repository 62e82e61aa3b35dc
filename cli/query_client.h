// Shared by the commands that call a running loci-server's Query service (`loci ask`,
// `loci objects`, `loci stats`): connection, deadline and the report of a failed call.
#pragma once

#include <grpcpp/client_context.h>

#include <memory>
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
// Reports a failed call and returns the exit code (1). With `json`, stdout gets the error as
// {"error":{"code":"INVALID_ARGUMENT","message":"..."}} (as the HTTP API), else stderr a line.
int ReportFailure(const std::string& server, const grpc::Status& s, bool json);

}  // namespace loci::cli
