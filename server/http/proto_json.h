// Protobuf messages as JSON with the proto3 JSON mapping (lowerCamelCase names, int64 as
// strings, enums by name, zero values printed), the one format of the HTTP API and `--json`.
#pragma once

#include <google/protobuf/message.h>

#include <string>

namespace loci::server {

// Compact JSON of `message` (never fails for valid UTF-8 strings; "{}" otherwise).
std::string ProtoToJson(const google::protobuf::Message& message);

// {"error":{"code":"NOT_FOUND","message":"..."}} for HTTP errors (code: gRPC code name).
std::string ErrorJson(const std::string& code_name, const std::string& message);

}  // namespace loci::server
