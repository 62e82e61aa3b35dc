#include "server/service/auth.h"

#include <fstream>
#include <sstream>

namespace loci::server {
namespace {

StatusOr<Principal> ParseRole(const std::string& role) {
  Principal p;
  if (role == "admin") {
    p.role = Principal::Role::kAdmin;
  } else if (role == "query") {
    p.role = Principal::Role::kQuery;
  } else if (role.rfind("robot:", 0) == 0 && role.size() > 6) {
    p.role = Principal::Role::kRobot;
    p.robot = role.substr(6);
  } else {
    return absl::InvalidArgumentError("role '" + role + "' is not admin, query or robot:NAME");
  }
  return p;
}

std::string RoleName(const Principal& p) {
  switch (p.role) {
    case Principal::Role::kAdmin: return "admin";
    case Principal::Role::kQuery: return "query";
    case Principal::Role::kRobot: return "robot:" + p.robot;
  }
  return "?";
}

}  // namespace

StatusOr<Authorizer> Authorizer::FromFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) return absl::NotFoundError("cannot read token file " + path);
  Authorizer auth;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (const size_t hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    std::istringstream fields(line);
    std::string token, role, extra;
    if (!(fields >> token)) continue;  // blank or comment
    const std::string where = absl::StrCat(path, ":", n, ": ");
    if (!(fields >> role) || (fields >> extra)) {
      return absl::InvalidArgumentError(where + "want `TOKEN ROLE`");
    }
    if (token.size() < 16) {
      return absl::InvalidArgumentError(where + "tokens need at least 16 characters");
    }
    auto p = ParseRole(role);
    if (!p.ok()) return absl::InvalidArgumentError(where + std::string(p.status().message()));
    if (!auth.tokens_.emplace(token, *p).second) {
      return absl::InvalidArgumentError(where + "the same token twice");
    }
  }
  if (auth.tokens_.empty()) return absl::InvalidArgumentError(path + ": no tokens");
  return auth;
}

StatusOr<Principal> Authorizer::Authenticate(
    std::optional<std::string_view> authorization) const {
  if (!enabled()) return Principal{};
  constexpr std::string_view kBearer = "Bearer ";
  if (!authorization || authorization->substr(0, kBearer.size()) != kBearer) {
    return absl::UnauthenticatedError(
        "missing bearer token (send `authorization: Bearer TOKEN`; loci tools: --token or "
        "LOCI_TOKEN)");
  }
  const auto it = tokens_.find(authorization->substr(kBearer.size()));
  if (it == tokens_.end()) return absl::UnauthenticatedError("unknown token");
  return it->second;
}

Status Authorizer::AllowRead(const Principal& who) {
  if (who.role != Principal::Role::kRobot) return absl::OkStatus();
  return absl::PermissionDeniedError(RoleName(who) + " may not read the map (needs query or admin)");
}

Status Authorizer::AllowRobot(const Principal& who, const std::string& robot) {
  if (who.role == Principal::Role::kAdmin ||
      (who.role == Principal::Role::kRobot && who.robot == robot)) {
    return absl::OkStatus();
  }
  return absl::PermissionDeniedError(
      absl::StrCat(RoleName(who), " may not open, write or close sessions of robot '", robot, "'"));
}

bool IsLoopback(const std::string& host) {
  return host == "localhost" || host == "::1" || host == "[::1]" || host.rfind("127.", 0) == 0;
}

}  // namespace loci::server
