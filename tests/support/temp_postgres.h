// A throwaway PostgreSQL server for tests: initdb into a fresh temporary folder, a postmaster on
// a free loopback port, trust authentication for the superuser `loci`, and a database `loci`.
// Durability is off (fsync, synchronous_commit, full_page_writes): the data dies with the test.
// PostgreSQL refuses to run as root, so as root the server runs as the `postgres` system user.
// The server dies with the thread that started it (PR_SET_PDEATHSIG), also when the test crashes.
#pragma once

#include <sys/types.h>

#include <memory>
#include <string>
#include <utility>

#include "common/status.h"

namespace loci::testing {

struct TempPostgresOptions {
  std::string bin_dir = "/usr/lib/postgresql/15/bin";  // initdb and postgres
};

class TempPostgres {
 public:
  // Returns once the server accepts connections (PQping OK, at most 30 s) and `loci` exists;
  // an error carries the tail of the server's log.
  static StatusOr<std::unique_ptr<TempPostgres>> Start(TempPostgresOptions options = {});
  // Whether the server binaries (and, as root, the `postgres` user) exist: tests skip otherwise.
  static bool Available(const TempPostgresOptions& options = {});

  ~TempPostgres();  // immediate shutdown (SIGQUIT), waits for the postmaster, removes the folder
  TempPostgres(const TempPostgres&) = delete;
  TempPostgres& operator=(const TempPostgres&) = delete;

  int port() const { return port_; }
  // "postgresql://loci@127.0.0.1:PORT/DBNAME"
  std::string Uri(const std::string& dbname = "loci") const;
  // CREATE DATABASE `name`: a fresh database per test keeps tests independent.
  Status CreateDatabase(const std::string& name);

 private:
  explicit TempPostgres(TempPostgresOptions options) : options_(std::move(options)) {}
  Status Init();
  Status StartServer();
  Status Stop();

  TempPostgresOptions options_;
  std::string dir_;  // the temporary folder: data/, the server log, the Unix socket
  uid_t uid_ = 0;    // the user the server runs as
  gid_t gid_ = 0;
  bool drop_root_ = false;
  pid_t pid_ = -1;  // the postmaster
  int port_ = 0;
};

}  // namespace loci::testing
