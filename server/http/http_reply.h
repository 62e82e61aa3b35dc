// Helpers shared by the HTTP API's handlers: error replies as {"error": {"code", "message"}},
// proto3 JSON replies, and strict parsing of query parameters.
#pragma once

#include <google/protobuf/message.h>
#include <grpcpp/support/status.h>

#include <charconv>
#include <string>
#include <vector>

#include "common/status.h"

namespace httplib {
struct Request;
struct Response;
}  // namespace httplib

namespace loci::server {

inline constexpr const char* kJsonType = "application/json";

// The HTTP status of an absl status code (400 / 401 / 403 / 404 / 409 / 500 / 501 / 503).
int HttpStatus(absl::StatusCode code);
// A failed status as HTTP: its status code and {"error": {"code", "message"}}.
void SendError(httplib::Response& res, const Status& status);
void SendInvalid(httplib::Response& res, const std::string& message);
// A QueryApi call's result: the message as proto3 JSON, or the error.
void SendGrpc(httplib::Response& res, const grpc::Status& s,
              const google::protobuf::Message& message);
// The status behind an HTTP error reply that has no body yet (httplib's own 400, 413, 414 ...).
Status StatusOfHttpError(int http_status, const httplib::Request& req);

bool ParseDouble(const std::string& s, double* out);  // finite numbers only
bool ParseBool(const std::string& s, bool* out);      // 1, 0, true, false
template <typename T>
bool ParseInt(const std::string& s, T* out) {
  const auto r = std::from_chars(s.data(), s.data() + s.size(), *out);
  return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

// Every value of a repeatable, comma-separated parameter (?class=cup,book&class=tv).
std::vector<std::string> ParamList(const httplib::Request& req, const std::string& name);

}  // namespace loci::server
