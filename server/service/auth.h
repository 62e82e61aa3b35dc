// Bearer-token authentication and roles for the gRPC and HTTP APIs.
//
// A token file holds one `TOKEN ROLE` per line ('#' starts a comment). Roles:
//   robot:NAME  may open, stream to and close only NAME's sessions;
//   query       may only read (the Query service and the HTTP API);
//   admin       may do anything.
// Clients send `authorization: Bearer TOKEN` (gRPC metadata or HTTP header). Without a token
// file every caller is admin; loci-server then binds loopback addresses only (IsLoopback).
#pragma once

#include <map>
#include <optional>
#include <string>
#include <string_view>

#include "common/status.h"

namespace loci::server {

struct Principal {
  enum class Role { kAdmin, kQuery, kRobot };
  Role role = Role::kAdmin;
  std::string robot;  // kRobot: the robot name the token is for
};

class Authorizer {
 public:
  // No tokens: everyone is admin.
  Authorizer() = default;
  // Reads a token file; InvalidArgument names the file and line of anything malformed.
  static StatusOr<Authorizer> FromFile(const std::string& path);

  bool enabled() const { return !tokens_.empty(); }
  // The caller behind an `authorization` header value ("Bearer TOKEN"); UNAUTHENTICATED when
  // tokens are enabled and it is missing or unknown.
  StatusOr<Principal> Authenticate(std::optional<std::string_view> authorization) const;

  // PERMISSION_DENIED unless `who` may read the map.
  static Status AllowRead(const Principal& who);
  // PERMISSION_DENIED unless `who` may open, write or close sessions of `robot`.
  static Status AllowRobot(const Principal& who, const std::string& robot);

 private:
  std::map<std::string, Principal, std::less<>> tokens_;
};

// TLS for a server: PEM files. An empty cert_file serves plaintext.
struct TlsFiles {
  std::string cert_file;       // server certificate (chain)
  std::string key_file;        // its private key
  std::string client_ca_file;  // optional: clients must present a certificate signed by it (mTLS)
};

// True for 127.0.0.0/8, ::1 and localhost (a HOST:PORT's host part).
bool IsLoopback(const std::string& host);

}  // namespace loci::server
