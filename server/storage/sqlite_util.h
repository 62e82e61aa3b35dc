// Small RAII helpers over the SQLite C API for the store: prepared statements, plain execution
// and transactions that roll back unless committed.
#pragma once

#include <sqlite3.h>

#include <cstdint>
#include <string>

#include "common/camera.h"
#include "common/se3.h"
#include "common/status.h"

namespace loci::server::sqlite {

Status SqlError(sqlite3* db, const std::string& what);
// Runs one or more statements without results.
Status Exec(sqlite3* db, const std::string& sql);

// A prepared statement, finalised on destruction.
class Stmt {
 public:
  Stmt(sqlite3* db, const char* sql);
  ~Stmt();
  Stmt(const Stmt&) = delete;
  Stmt& operator=(const Stmt&) = delete;

  Status status() const;  // of the prepare
  Stmt& Bind(int i, int64_t v);
  Stmt& Bind(int i, double v);
  Stmt& BindText(int i, const std::string& v);
  // The blob must outlive the statement's execution (SQLITE_STATIC).
  Stmt& BindBlob(int i, const std::string& v);
  int Step();
  // Ready to run again with new bindings (the old ones stay until rebound).
  void Reset();
  int64_t Int(int c) const;
  double Real(int c) const;
  bool IsNull(int c) const;
  std::string Text(int c) const;  // text or blob column

 private:
  sqlite3* db_;
  sqlite3_stmt* stmt_ = nullptr;
  int rc_;
};

// BEGIN IMMEDIATE on construction; ROLLBACK on destruction unless Commit succeeded, so an error
// on the way and a failed COMMIT (busy, a deferred constraint) both leave no open transaction.
class Transaction {
 public:
  explicit Transaction(sqlite3* db);
  ~Transaction();
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;

  const Status& status() const { return begin_; }  // of the BEGIN
  Status Commit();

 private:
  sqlite3* db_;
  Status begin_;
  bool open_ = false;
};

// Row readers of the store's columns: a pose (tx ty tz qw qx qy qz) and a camera
// (fx fy cx cy width_px height_px) starting at column c.
SE3d PoseFrom(const Stmt& s, int c);
// Binds a pose to parameters i .. i + 6 in the same order.
void BindPose(Stmt& s, int i, const SE3d& T);
PinholeCamera CameraFrom(const Stmt& s, int c);

}  // namespace loci::server::sqlite
