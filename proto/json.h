// Protobuf messages as JSON with the proto3 JSON mapping (lowerCamelCase names, int64 as
// strings, enums by name, zero values printed): the one JSON format of the HTTP API and of the
// CLI's `--json`. Beside the protos so that JSON printing needs nothing but them.
#pragma once

#include <google/protobuf/message.h>

#include <string>

#include "absl/status/status.h"

namespace loci {

// Compact JSON of `message` (never fails for valid UTF-8 strings; "{}" otherwise).
std::string ProtoToJson(const google::protobuf::Message& message);

// Parses proto3 JSON into `message`; InvalidArgument naming the problem.
absl::Status JsonToProto(const std::string& json, google::protobuf::Message* message);

// {"error":{"code":"NOT_FOUND","message":"..."}} for a failed status; the code is absl's name
// of the status code (absl::StatusCodeToString), the same names gRPC uses.
std::string ErrorJson(const absl::Status& status);

}  // namespace loci
