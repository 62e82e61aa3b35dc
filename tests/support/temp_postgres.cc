#include "tests/support/temp_postgres.h"

#include <fcntl.h>
#include <grp.h>
#include <gtest/gtest.h>
#include <libpq-fe.h>
#include <netinet/in.h>
#include <pwd.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <thread>
#include <vector>

namespace loci::testing {
namespace {

constexpr auto kReadyTimeout = std::chrono::seconds(30);
constexpr int kPortAttempts = 3;
constexpr size_t kLogTailBytes = 2000;
constexpr size_t kMaxSocketPath = 107;  // sizeof(sockaddr_un::sun_path) - 1

std::string Tail(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (text.size() > kLogTailBytes) text = "..." + text.substr(text.size() - kLogTailBytes);
  return text.empty() ? "(empty log " + path + ")" : text;
}

// A port the kernel just handed out on 127.0.0.1. Another process may take it before the
// postmaster binds it; Start then retries with a new one.
StatusOr<int> FreePort() {
  const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return absl::InternalError("socket() failed");
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof(addr);
  const bool ok = bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) == 0 &&
                  getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) == 0;
  close(fd);
  if (!ok) return absl::InternalError("could not bind 127.0.0.1:0");
  return ntohs(addr.sin_port);
}

// Whether every ancestor of `path` lets other users through: the postgres user must reach it.
bool OthersCanTraverse(const std::filesystem::path& path) {
  for (std::filesystem::path p = std::filesystem::absolute(path); !p.empty(); p = p.parent_path()) {
    struct stat st {};
    if (stat(p.c_str(), &st) != 0 || (st.st_mode & S_IXOTH) == 0) return false;
    if (p == p.parent_path()) break;
  }
  return true;
}

std::string ConnInfo(int port, const std::string& dbname) {
  // Explicit settings win over the PG* environment of whoever runs the tests.
  return absl::StrCat("host=127.0.0.1 port=", port, " user=loci dbname=", dbname,
                      " connect_timeout=5 sslmode=disable gssencmode=disable");
}

struct Argv {
  explicit Argv(std::vector<std::string> a) : args(std::move(a)) {
    for (std::string& s : args) ptrs.push_back(s.data());
    ptrs.push_back(nullptr);
  }
  std::vector<std::string> args;
  std::vector<char*> ptrs;
};

struct Identity {
  bool drop_root;
  uid_t uid;
  gid_t gid;
};

// Starts argv[0] with stdout and stderr appended to `log_path`, in `cwd`, as `who`, with a fixed
// environment (no PG* variables, C messages, UTC so initdb need not probe the time zone).
StatusOr<pid_t> Spawn(const Argv& argv, const std::string& log_path, const std::string& cwd,
                      const Identity& who) {
  const int log = open(log_path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (log < 0) return absl::InternalError("cannot open " + log_path);
  Argv env({"PATH=/usr/bin:/bin", "LC_ALL=C", "TZ=UTC"});
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid == 0) {
    // In the child: only async-signal-safe calls (the test process has threads).
    const int null = open("/dev/null", O_RDONLY);
    if (null < 0 || dup2(null, STDIN_FILENO) < 0 || dup2(log, STDOUT_FILENO) < 0 ||
        dup2(log, STDERR_FILENO) < 0 || chdir(cwd.c_str()) != 0) {
      _exit(126);
    }
    if (who.drop_root &&
        (setgroups(0, nullptr) != 0 || setgid(who.gid) != 0 || setuid(who.uid) != 0)) {
      _exit(126);
    }
    // A crashed or killed test (a ctest timeout) takes its server down too. Set after setuid,
    // which clears it; it fires when the forking thread ends, so Start from a thread that lives.
    if (prctl(PR_SET_PDEATHSIG, SIGQUIT) != 0 || getppid() != parent) _exit(126);
    // The server must not hold the test's sockets and files open.
    for (int fd = 3; fd < 1024; ++fd) close(fd);
    execve(argv.ptrs[0], argv.ptrs.data(), env.ptrs.data());
    _exit(127);
  }
  close(log);
  if (pid < 0) return absl::InternalError("fork() failed");
  return pid;
}

// The exit status of `pid` if it has ended, -1 while it runs.
int Reap(pid_t pid) {
  int status = 0;
  return waitpid(pid, &status, WNOHANG) == pid ? status : -1;
}

}  // namespace

bool TempPostgres::Available(const TempPostgresOptions& options) {
  for (const char* bin : {"/initdb", "/postgres"}) {
    if (access((options.bin_dir + bin).c_str(), X_OK) != 0) return false;
  }
  return geteuid() != 0 || getpwnam("postgres") != nullptr;
}

StatusOr<std::unique_ptr<TempPostgres>> TempPostgres::Start(TempPostgresOptions options) {
  // The object exists from the start, so its destructor cleans up after any failing step.
  std::unique_ptr<TempPostgres> pg(new TempPostgres(std::move(options)));
  LOCI_RETURN_IF_ERROR(pg->Init());
  LOCI_RETURN_IF_ERROR(pg->StartServer());
  LOCI_RETURN_IF_ERROR(pg->CreateDatabase("loci"));
  return pg;
}

Status TempPostgres::Init() {
  uid_ = geteuid();
  gid_ = getegid();
  drop_root_ = uid_ == 0;
  if (drop_root_) {
    const passwd* pw = getpwnam("postgres");
    if (pw == nullptr) return absl::FailedPreconditionError("running as root, no user postgres");
    uid_ = pw->pw_uid;
    gid_ = pw->pw_gid;
  }
  // The Unix socket path has a length limit, and the postgres user needs a way in: /tmp when
  // the test temp folder fails either.
  std::string base = ::testing::TempDir();
  if (base.size() + 40 > kMaxSocketPath || (drop_root_ && !OthersCanTraverse(base))) {
    base = "/tmp";
  }
  std::string templ = (std::filesystem::path(base) / "loci_pg_XXXXXX").string();
  if (mkdtemp(templ.data()) == nullptr) return absl::InternalError("mkdtemp in " + base);
  dir_ = templ;
  if (drop_root_ && chown(dir_.c_str(), uid_, gid_) != 0) {
    return absl::InternalError("cannot chown " + dir_ + " to postgres");
  }

  const std::string log = dir_ + "/initdb.log";
  const Argv argv({options_.bin_dir + "/initdb", "-D", dir_ + "/data", "--auth=trust",
                   "--username=loci", "--encoding=UTF8", "--no-locale", "--no-sync",
                   "--no-instructions"});
  LOCI_ASSIGN_OR_RETURN(const pid_t pid, Spawn(argv, log, dir_, {drop_root_, uid_, gid_}));
  int status = 0;
  waitpid(pid, &status, 0);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    return absl::InternalError(
        absl::StrCat("initdb failed (wait status ", status, "):\n", Tail(log)));
  }
  return absl::OkStatus();
}

Status TempPostgres::StartServer() {
  const std::string log = dir_ + "/postgres.log";
  for (int attempt = 1;; ++attempt) {
    LOCI_ASSIGN_OR_RETURN(port_, FreePort());
    const Argv argv({options_.bin_dir + "/postgres", "-D", dir_ + "/data", "-p",
                     std::to_string(port_), "-c", "listen_addresses=127.0.0.1", "-c",
                     "unix_socket_directories=" + dir_, "-c", "fsync=off", "-c",
                     "synchronous_commit=off", "-c", "full_page_writes=off"});
    LOCI_ASSIGN_OR_RETURN(pid_, Spawn(argv, log, dir_, {drop_root_, uid_, gid_}));
    const std::string conninfo = ConnInfo(port_, "postgres");
    const auto deadline = std::chrono::steady_clock::now() + kReadyTimeout;
    // PQping is OK only once the server accepts sessions (REJECT while it starts up).
    while (PQping(conninfo.c_str()) != PQPING_OK) {
      const int status = Reap(pid_);
      if (status >= 0) {
        pid_ = -1;
        const std::string tail = Tail(log);
        const bool port_taken = tail.find("could not bind") != std::string::npos ||
                                tail.find("could not create any TCP/IP") != std::string::npos;
        if (port_taken && attempt < kPortAttempts) break;
        return absl::UnavailableError(
            absl::StrCat("postgres ended (wait status ", status, ") on port ", port_, ":\n", tail));
      }
      if (std::chrono::steady_clock::now() > deadline) {
        return absl::DeadlineExceededError(
            absl::StrCat("postgres not ready on port ", port_, " after 30 s:\n", Tail(log)));
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    if (pid_ > 0) return absl::OkStatus();
  }
}

Status TempPostgres::Stop() {
  if (pid_ <= 0) return absl::OkStatus();
  // Immediate shutdown: the postmaster ends its backends and exits without a checkpoint.
  kill(pid_, SIGQUIT);
  int status = 0;
  const bool reaped = waitpid(pid_, &status, 0) == pid_;
  pid_ = -1;
  if (!reaped) return absl::InternalError("waitpid on the postmaster failed");
  return absl::OkStatus();
}

TempPostgres::~TempPostgres() {
  Stop().IgnoreError();
  if (!dir_.empty()) {
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  }
}

std::string TempPostgres::Uri(const std::string& dbname) const {
  return absl::StrCat("postgresql://loci@127.0.0.1:", port_, "/", dbname);
}

Status TempPostgres::CreateDatabase(const std::string& name) {
  std::unique_ptr<PGconn, decltype(&PQfinish)> conn(
      PQconnectdb(ConnInfo(port_, "postgres").c_str()), &PQfinish);
  if (PQstatus(conn.get()) != CONNECTION_OK) {
    return absl::UnavailableError(absl::StrCat("connect: ", PQerrorMessage(conn.get())));
  }
  std::unique_ptr<char, decltype(&PQfreemem)> id(
      PQescapeIdentifier(conn.get(), name.data(), name.size()), &PQfreemem);
  if (id == nullptr) return absl::InvalidArgumentError("bad database name " + name);
  std::unique_ptr<PGresult, decltype(&PQclear)> res(
      PQexec(conn.get(), absl::StrCat("CREATE DATABASE ", id.get()).c_str()), &PQclear);
  if (PQresultStatus(res.get()) != PGRES_COMMAND_OK) {
    return absl::InternalError(
        absl::StrCat("CREATE DATABASE ", name, ": ", PQerrorMessage(conn.get())));
  }
  return absl::OkStatus();
}

}  // namespace loci::testing
