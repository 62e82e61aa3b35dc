#include "tests/support/server_process.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>

namespace loci::testing {
namespace {

std::vector<std::string> Args(const ServerProcessOptions& o) {
  std::vector<std::string> args{LOCI_SERVER_BIN, "--db",        o.db,  "--listen",
                                o.listen,        "--log-level", "warn"};
  if (!o.config.empty()) args.insert(args.end(), {"--config", o.config});
  args.insert(args.end(), o.extra_args.begin(), o.extra_args.end());
  return args;
}

// In the child: only async-signal-safe calls (the test process has threads).
[[noreturn]] void ExecServer(char* const* argv, const char* stderr_path, int stdout_fd) {
  dup2(stdout_fd, STDOUT_FILENO);
  if (stderr_path != nullptr) {
    const int err = open(stderr_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (err >= 0) dup2(err, STDERR_FILENO);
  }
  execv(argv[0], argv);
  _exit(127);
}

}  // namespace

ServerProcess::ServerProcess(ServerProcessOptions options) {
  std::vector<std::string> args = Args(options);
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const char* stderr_path = options.stderr_path.empty() ? nullptr : options.stderr_path.c_str();
  int fds[2];
  if (pipe(fds) != 0) return;
  pid_ = fork();
  if (pid_ == 0) {
    close(fds[0]);
    ExecServer(argv.data(), stderr_path, fds[1]);
  }
  close(fds[1]);
  out_ = fdopen(fds[0], "r");
  const auto& x = options.extra_args;
  const auto http = std::find(x.begin(), x.end(), "--http");
  ReadReadyLines(http != x.end() && http + 1 != x.end() && *(http + 1) != "off");
  const bool tls = std::find(x.begin(), x.end(), "--tls-cert") != x.end();
  if (port_ != 0 && !tls) serving_ = WaitServing(ChannelSecurity{});
}

Status ServerProcess::WaitServing(const ChannelSecurity& security) {
  if (port_ == 0) return absl::UnavailableError("the server ended before listening");
  LOCI_ASSIGN_OR_RETURN(std::shared_ptr<grpc::Channel> channel,
                        MakeChannel(address(), security));
  // The health service turns SERVING once the map is loaded: a real signal, no fixed wait.
  return loci::WaitForServing(*channel,
                              std::chrono::system_clock::now() + std::chrono::minutes(5));
}

void ServerProcess::ReadReadyLines(bool want_http) {
  char line[256] = {0};
  // Blocks until the server prints the line or ends (EOF): no polling, no fixed waits.
  while (port_ == 0 && fgets(line, sizeof(line), out_) != nullptr) {
    std::sscanf(line, "listening on %*[^:]:%d", &port_);
  }
  while (want_http && http_port_ == 0 && fgets(line, sizeof(line), out_) != nullptr) {
    std::sscanf(line, "http on %*[^:]:%d", &http_port_);
  }
}

int ServerProcess::Stop(int sig) {
  if (pid_ <= 0) return -1;
  if (sig != 0) kill(pid_, sig);
  int status = 0;
  waitpid(pid_, &status, 0);
  pid_ = -1;
  return status;
}

ServerProcess::~ServerProcess() {
  Stop(SIGKILL);
  if (out_) fclose(out_);
}

}  // namespace loci::testing
