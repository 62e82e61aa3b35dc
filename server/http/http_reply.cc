#include "server/http/http_reply.h"

#include <cmath>

#include "proto/json.h"
#include "server/service/services.h"

// Last: httplib pulls <resolv.h>, whose `_res` macro breaks Eigen headers included after it.
#include <httplib.h>

namespace loci::server {

int HttpStatus(absl::StatusCode code) {
  switch (code) {
    case absl::StatusCode::kOk:
      return 200;
    case absl::StatusCode::kInvalidArgument:
    case absl::StatusCode::kOutOfRange:
      return 400;
    case absl::StatusCode::kUnauthenticated:
      return 401;
    case absl::StatusCode::kPermissionDenied:
      return 403;
    case absl::StatusCode::kNotFound:
      return 404;
    case absl::StatusCode::kFailedPrecondition:
      return 409;
    case absl::StatusCode::kUnimplemented:
      return 501;
    case absl::StatusCode::kUnavailable:
      return 503;
    default:
      return 500;
  }
}

void SendError(httplib::Response& res, const Status& status) {
  res.status = HttpStatus(status.code());
  res.set_content(ErrorJson(status), kJsonType);
}

void SendInvalid(httplib::Response& res, const std::string& message) {
  SendError(res, absl::InvalidArgumentError(message));
}

void SendGrpc(httplib::Response& res, const grpc::Status& s,
              const google::protobuf::Message& message) {
  if (!s.ok()) return SendError(res, FromGrpc(s));
  res.status = 200;
  res.set_content(ProtoToJson(message), kJsonType);
}

Status StatusOfHttpError(int http_status, const httplib::Request& req) {
  switch (http_status) {
    case 404:
      return absl::NotFoundError(
          "no endpoint " + req.method + " " + req.path +
          "; known: / (the viewer), /api/ask, /api/objects, /api/objects/{id}, /api/stats, "
          "/api/cloud, /api/trajectories, /api/events");
    case 413:
      return absl::OutOfRangeError("request body too large");
    case 414:
      return absl::OutOfRangeError("request URI too long");
    case 405:
      return absl::UnimplementedError("method " + req.method + " not allowed");
    default:
      return Status(http_status < 500 ? absl::StatusCode::kInvalidArgument
                                      : absl::StatusCode::kInternal,
                    absl::StrCat("HTTP ", http_status));
  }
}

bool ParseDouble(const std::string& s, double* out) {
  try {
    size_t used = 0;
    *out = std::stod(s, &used);
    return used == s.size() && std::isfinite(*out);
  } catch (...) {
    return false;
  }
}

bool ParseBool(const std::string& s, bool* out) {
  if (s == "1" || s == "true") return (*out = true), true;
  if (s == "0" || s == "false") return (*out = false), true;
  return false;
}

std::vector<std::string> ParamList(const httplib::Request& req, const std::string& name) {
  std::vector<std::string> out;
  for (size_t i = 0; i < req.get_param_value_count(name.c_str()); ++i) {
    const std::string v = req.get_param_value(name.c_str(), i);
    for (size_t b = 0; b <= v.size();) {
      size_t e = v.find(',', b);
      if (e == std::string::npos) e = v.size();
      if (e > b) out.push_back(v.substr(b, e - b));
      b = e + 1;
    }
  }
  return out;
}

}  // namespace loci::server
