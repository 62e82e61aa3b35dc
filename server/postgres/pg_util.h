// Small RAII helpers over libpq for the PostgreSQL store: connections, typed parameters sent in
// binary, results read in binary (exact doubles, raw bytea) and transactions that roll back
// unless committed.
#pragma once

#include <libpq-fe.h>

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "common/camera.h"
#include "common/se3.h"
#include "common/status.h"

namespace loci::server::pg {

// Opens a connection to `uri` (a libpq connection string or postgresql:// URI) and sets its
// search path to `schema`, then public (where PostGIS lives); "" keeps the default path.
StatusOr<PGconn*> Connect(const std::string& uri, const std::string& schema);
// Whether the connection still works (a server restart breaks it).
bool Healthy(PGconn* conn);

// Parameters of one statement, in $1, $2, ... order.
class Params {
 public:
  Params& Int(int64_t v);
  Params& Real(double v);
  Params& Bool(bool v);
  Params& Text(std::string_view v);
  Params& Bytes(std::string_view v);
  // A pose as seven doubles: tx ty tz qw qx qy qz.
  Params& Pose(const SE3d& T);
  // fx fy cx cy as doubles, width_px height_px as integers.
  Params& Camera(const PinholeCamera& c);
  size_t size() const { return values_.size(); }
  // For Exec: the values and their type oids, lengths and formats (all binary).
  const std::vector<std::string>& values() const { return values_; }
  const Oid* types() const { return types_.data(); }
  const int* lengths() const { return lengths_.data(); }
  const int* formats() const { return formats_.data(); }

 private:
  std::vector<std::string> values_;
  std::vector<Oid> types_;
  std::vector<int> lengths_;
  std::vector<int> formats_;
};

// A result in binary format; readers check the column's type.
class Result {
 public:
  explicit Result(PGresult* r) : r_(r, &PQclear) {}
  const PGresult* get() const { return r_.get(); }
  int rows() const { return PQntuples(r_.get()); }
  // Rows an INSERT, UPDATE or DELETE touched.
  int64_t affected() const;
  bool IsNull(int row, int col) const { return PQgetisnull(r_.get(), row, col) != 0; }
  int64_t Int(int row, int col) const;  // int2, int4, int8 or bool
  double Real(int row, int col) const;  // float8 or float4
  bool Bool(int row, int col) const { return Int(row, col) != 0; }
  std::string Bytes(int row, int col) const;  // bytea or text, raw
  // Seven columns from `col`: tx ty tz qw qx qy qz.
  SE3d Pose(int row, int col) const;
  // Six columns from `col`: fx fy cx cy width_px height_px.
  PinholeCamera Camera(int row, int col) const;

 private:
  std::unique_ptr<PGresult, decltype(&PQclear)> r_;
};

// Runs one statement with parameters; `what` names it in the error.
StatusOr<Result> Exec(PGconn* conn, const std::string& sql, const Params& params,
                      const std::string& what);
// Runs a script of statements without parameters or results (migrations, BEGIN, COMMIT).
Status ExecScript(PGconn* conn, const std::string& sql, const std::string& what);

// BEGIN on construction; ROLLBACK on destruction unless Commit succeeded.
class Transaction {
 public:
  explicit Transaction(PGconn* conn);
  ~Transaction();
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  const Status& status() const { return begin_; }
  Status Commit();

 private:
  PGconn* conn_;
  Status begin_;
  bool open_ = false;
};

}  // namespace loci::server::pg
