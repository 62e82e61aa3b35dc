#include "server/http/http_api.h"

#include <httplib.h>

#include <charconv>
#include <cmath>
#include <optional>

#include "proto/json.h"

namespace loci::server {
namespace {

constexpr const char* kJson = "application/json";

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

// A failed status as HTTP: its status code and {"error": {"code", "message"}}.
void SendError(httplib::Response& res, const Status& status) {
  res.status = HttpStatus(status.code());
  res.set_content(ErrorJson(status), kJson);
}

void SendGrpc(httplib::Response& res, const grpc::Status& s,
              const google::protobuf::Message& message) {
  if (!s.ok()) return SendError(res, FromGrpc(s));
  res.status = 200;
  res.set_content(ProtoToJson(message), kJson);
}

void SendInvalid(httplib::Response& res, const std::string& message) {
  SendError(res, absl::InvalidArgumentError(message));
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

template <typename T>
bool ParseInt(const std::string& s, T* out) {
  const auto r = std::from_chars(s.data(), s.data() + s.size(), *out);
  return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

bool ParseBool(const std::string& s, bool* out) {
  if (s == "1" || s == "true") return (*out = true), true;
  if (s == "0" || s == "false") return (*out = false), true;
  return false;
}

// The status behind an HTTP error reply that has no body yet (httplib's own 400, 413, 414 ...).
Status StatusOfHttpError(int http_status, const httplib::Request& req) {
  switch (http_status) {
    case 404:
      return absl::NotFoundError("no endpoint " + req.method + " " + req.path +
                                 "; known: /api/ask, /api/objects, /api/objects/{id}, /api/stats");
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

constexpr size_t kMaxBodyBytes = 64 * 1024;
constexpr int kTimeoutS = 5;
constexpr int kKeepAliveS = 2;
constexpr int kWorkerThreads = 32;

}  // namespace

StatusOr<std::unique_ptr<HttpApi>> HttpApi::Start(QueryService* service,
                                                  const std::string& listen,
                                                  const Authorizer* auth, const TlsFiles& tls) {
  const size_t colon = listen.rfind(':');
  int port = -1;
  if (colon == std::string::npos || !ParseInt(listen.substr(colon + 1), &port) || port < 0 ||
      port > 65535) {
    return absl::InvalidArgumentError("--http wants HOST:PORT or off, got '" + listen + "'");
  }
  const std::string host = listen.substr(0, colon);
  std::unique_ptr<HttpApi> api(new HttpApi());
  api->service_ = service;
  api->auth_ = auth;
  if (tls.cert_file.empty()) {
    api->http_ = std::make_unique<httplib::Server>();
  } else {
    auto https = std::make_unique<httplib::SSLServer>(
        tls.cert_file.c_str(), tls.key_file.c_str(),
        tls.client_ca_file.empty() ? nullptr : tls.client_ca_file.c_str());
    if (!https->is_valid()) {
      return absl::InvalidArgumentError("HTTPS: cannot load the TLS certificate or key (" +
                                        tls.cert_file + ", " + tls.key_file + ")");
    }
    api->http_ = std::move(https);
  }
  api->Harden();
  api->Route();
  if (port == 0) {
    api->port_ = api->http_->bind_to_any_port(host);
  } else {
    api->port_ = api->http_->bind_to_port(host, port) ? port : -1;
  }
  if (api->port_ <= 0) {
    return absl::UnavailableError("HTTP API cannot listen on " + listen);
  }
  api->thread_ = std::thread([raw = api.get()] { raw->http_->listen_after_bind(); });
  return api;
}

HttpApi::~HttpApi() { Shutdown(); }

void HttpApi::Shutdown() {
  if (http_) http_->stop();
  if (thread_.joinable()) thread_.join();
}

void HttpApi::Harden() {
  http_->set_payload_max_length(kMaxBodyBytes);
  http_->set_read_timeout(kTimeoutS, 0);
  http_->set_write_timeout(kTimeoutS, 0);
  http_->set_idle_interval(0, 100'000);
  http_->set_keep_alive_timeout(kKeepAliveS);
  http_->new_task_queue = [] { return new httplib::ThreadPool(kWorkerThreads); };
  http_->set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
    if (auth_ == nullptr || !auth_->enabled()) return httplib::Server::HandlerResponse::Unhandled;
    const std::string value = req.get_header_value("Authorization");  // owns the bytes
    std::optional<std::string_view> header;
    if (req.has_header("Authorization")) header = value;
    StatusOr<Principal> who = auth_->Authenticate(header);
    Status allowed = who.ok() ? Authorizer::AllowRead(*who) : who.status();
    if (allowed.ok()) return httplib::Server::HandlerResponse::Unhandled;
    SendError(res, allowed);
    return httplib::Server::HandlerResponse::Handled;
  });
}

void HttpApi::Route() {
  http_->Get("/api/ask", [this](const httplib::Request& req, httplib::Response& res) {
    if (!req.has_param("q")) {
      return SendInvalid(res,
                         "missing query parameter q (the question), e.g. /api/ask?q=where+"
                         "is+the+book");
    }
    loci::v1::AskRequest ask;
    ask.set_text(req.get_param_value("q"));
    ask.set_robot_name(req.get_param_value("robot"));
    loci::v1::AskResponse resp;
    SendGrpc(res, service_->Ask(ask, &resp), resp);
  });
  http_->Get("/api/objects", [this](const httplib::Request& req, httplib::Response& res) {
    loci::v1::FindObjectsRequest find;
    for (size_t i = 0; i < req.get_param_value_count("class"); ++i) {
      const std::string v = req.get_param_value("class", i);
      for (size_t b = 0; b <= v.size();) {
        size_t e = v.find(',', b);
        if (e == std::string::npos) e = v.size();
        if (e > b) find.add_classes(v.substr(b, e - b));
        b = e + 1;
      }
    }
    if (req.has_param("min_confidence")) {
      double c = 0;
      if (!ParseDouble(req.get_param_value("min_confidence"), &c) || c < 0 || c > 1) {
        return SendInvalid(res, "min_confidence must be a number in [0, 1]");
      }
      find.set_min_confidence(c);
    }
    if (req.has_param("confirmed_only")) {
      bool b = false;
      if (!ParseBool(req.get_param_value("confirmed_only"), &b)) {
        return SendInvalid(res, "confirmed_only must be 0, 1, true or false");
      }
      find.set_confirmed_only(b);
    }
    if (req.has_param("limit")) {
      uint32_t limit = 0;
      if (!ParseInt(req.get_param_value("limit"), &limit)) {
        return SendInvalid(res, "limit must be a non-negative integer");
      }
      find.set_limit(limit);
    }
    loci::v1::FindObjectsResponse resp;
    SendGrpc(res, service_->FindObjects(find, &resp), resp);
  });
  http_->Get(R"(/api/objects/([^/]+))", [this](const httplib::Request& req,
                                               httplib::Response& res) {
    loci::v1::GetObjectRequest get;
    int64_t id = 0;
    if (!ParseInt(req.matches[1].str(), &id)) {
      return SendInvalid(res, "object id must be an integer, got '" + req.matches[1].str() + "'");
    }
    get.set_id(id);
    if (req.has_param("with_cloud")) {
      bool b = false;
      if (!ParseBool(req.get_param_value("with_cloud"), &b)) {
        return SendInvalid(res, "with_cloud must be 0, 1, true or false");
      }
      get.set_with_cloud(b);
    }
    loci::v1::GetObjectResponse resp;
    SendGrpc(res, service_->GetObject(get, &resp), resp);
  });
  http_->Get("/api/stats", [this](const httplib::Request&, httplib::Response& res) {
    loci::v1::GetStatsResponse resp;
    SendGrpc(res, service_->GetStats(&resp), resp);
  });
  // Every error reply without a body (unknown paths, httplib's 400/413/414): a JSON body.
  http_->set_error_handler([](const httplib::Request& req, httplib::Response& res) {
    if (res.body.empty()) res.set_content(ErrorJson(StatusOfHttpError(res.status, req)), kJson);
  });
  http_->set_exception_handler(
      [](const httplib::Request&, httplib::Response& res, std::exception_ptr) {
        SendError(res, absl::InternalError("internal error"));
      });
}

}  // namespace loci::server
