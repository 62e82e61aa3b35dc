// A loci-server child process for tests. The constructor waits for "listening on HOST:PORT"
// (the port is bound; the map may still be loading), or for the process to end before it, and
// then, for a plaintext server, for the gRPC health service to report SERVING (map loaded).
#pragma once

#include <sys/types.h>

#include <cstdio>

#include "common/status.h"
#include "proto/channel.h"
#include <string>
#include <vector>

namespace loci::testing {

struct ServerProcessOptions {
  std::string db{};                       // --db
  std::string config{};                   // --config; "" = none
  std::string listen = "127.0.0.1:0";     // --listen; port 0 = any free port
  std::vector<std::string> extra_args{};  // e.g. {"--http", "127.0.0.1:0", "--strict-config"}
  std::string stderr_path{};              // the child's stderr; "" = this process's stderr
};

class ServerProcess {
 public:
  explicit ServerProcess(ServerProcessOptions options);
  ~ServerProcess();  // SIGKILL when still running
  ServerProcess(const ServerProcess&) = delete;
  ServerProcess& operator=(const ServerProcess&) = delete;

  // The bound gRPC port; 0 when the server ended before listening (Stop gives its status).
  int port() const { return port_; }
  pid_t pid() const { return pid_; }
  // The HTTP port from "http on HOST:PORT" (0 without --http).
  int http_port() const { return http_port_; }
  std::string address() const { return "127.0.0.1:" + std::to_string(port_); }
  // Waits for health SERVING over a channel with `security` (TLS servers; the constructor
  // already waited for plaintext ones: serving()).
  Status WaitServing(const ChannelSecurity& security);
  const Status& serving() const { return serving_; }
  // Sends `sig` (0: none, only waits) and returns the wait status; -1 when not running.
  int Stop(int sig);

 private:
  void ReadReadyLines(bool want_http);

  pid_t pid_ = -1;
  int port_ = 0;
  int http_port_ = 0;
  FILE* out_ = nullptr;
  Status serving_;
};

}  // namespace loci::testing
