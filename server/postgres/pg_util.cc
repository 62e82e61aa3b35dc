#include "server/postgres/pg_util.h"

#include <endian.h>

#include <cstring>

#include "absl/strings/str_cat.h"

namespace loci::server::pg {
namespace {

// Type oids of pg_type.dat (stable across PostgreSQL versions).
constexpr Oid kBoolOid = 16, kByteaOid = 17, kInt8Oid = 20, kInt2Oid = 21, kInt4Oid = 23,
              kTextOid = 25, kFloat4Oid = 700, kFloat8Oid = 701;

std::string BigEndian64(uint64_t v) {
  const uint64_t be = htobe64(v);
  return std::string(reinterpret_cast<const char*>(&be), 8);
}

// The gRPC-style code of a failed statement, from its SQLSTATE class.
Status ErrorFrom(PGconn* conn, const PGresult* r, const std::string& what) {
  const char* state = r ? PQresultErrorField(r, PG_DIAG_SQLSTATE) : nullptr;
  const std::string sqlstate = state ? state : "";
  std::string message = r ? PQresultErrorMessage(r) : PQerrorMessage(conn);
  while (!message.empty() && (message.back() == '\n' || message.back() == ' ')) message.pop_back();
  const std::string text = absl::StrCat(what, ": ", message,
                                        sqlstate.empty() ? "" : absl::StrCat(" [", sqlstate, "]"));
  if (PQstatus(conn) != CONNECTION_OK || sqlstate.rfind("08", 0) == 0 ||
      sqlstate.rfind("57P", 0) == 0) {
    return absl::UnavailableError(text);
  }
  if (sqlstate == "40001" || sqlstate == "40P01") return absl::AbortedError(text);
  if (sqlstate.rfind("23", 0) == 0) return absl::FailedPreconditionError(text);
  return absl::InternalError(text);
}

}  // namespace

StatusOr<PGconn*> Connect(const std::string& uri, const std::string& schema) {
  PGconn* conn = PQconnectdb(uri.c_str());
  if (conn == nullptr) return absl::ResourceExhaustedError("libpq: out of memory");
  if (PQstatus(conn) != CONNECTION_OK) {
    std::string message = PQerrorMessage(conn);
    while (!message.empty() && message.back() == '\n') message.pop_back();
    PQfinish(conn);
    return absl::UnavailableError(absl::StrCat("cannot connect to PostgreSQL: ", message));
  }
  Status s = ExecScript(conn, "SET client_min_messages = warning", "set message level");
  if (s.ok() && !schema.empty()) {
    // The schema name is checked by the caller (site names are [a-z0-9_]).
    s = ExecScript(conn, absl::StrCat("SET search_path TO ", schema, ", public"),
                   "set search path");
  }
  if (!s.ok()) {
    PQfinish(conn);
    return s;
  }
  return conn;
}

bool Healthy(PGconn* conn) { return conn != nullptr && PQstatus(conn) == CONNECTION_OK; }

Params& Params::Int(int64_t v) {
  values_.push_back(BigEndian64(static_cast<uint64_t>(v)));
  types_.push_back(kInt8Oid);
  lengths_.push_back(8);
  formats_.push_back(1);
  return *this;
}

Params& Params::Real(double v) {
  uint64_t bits;
  std::memcpy(&bits, &v, 8);
  values_.push_back(BigEndian64(bits));
  types_.push_back(kFloat8Oid);
  lengths_.push_back(8);
  formats_.push_back(1);
  return *this;
}

Params& Params::Bool(bool v) {
  values_.push_back(std::string(1, v ? '\1' : '\0'));
  types_.push_back(kBoolOid);
  lengths_.push_back(1);
  formats_.push_back(1);
  return *this;
}

Params& Params::Text(std::string_view v) {
  values_.emplace_back(v);
  types_.push_back(kTextOid);
  lengths_.push_back(static_cast<int>(v.size()));
  formats_.push_back(1);
  return *this;
}

Params& Params::Bytes(std::string_view v) {
  values_.emplace_back(v);
  types_.push_back(kByteaOid);
  lengths_.push_back(static_cast<int>(v.size()));
  formats_.push_back(1);
  return *this;
}

Params& Params::Pose(const SE3d& T) {
  const Vec3d t = T.translation();
  const Quatd q(T.rotation());
  return Real(t.x()).Real(t.y()).Real(t.z()).Real(q.w()).Real(q.x()).Real(q.y()).Real(q.z());
}

Params& Params::Camera(const PinholeCamera& c) {
  return Real(c.fx).Real(c.fy).Real(c.cx).Real(c.cy).Int(c.width_px).Int(c.height_px);
}

int64_t Result::affected() const {
  const char* n = PQcmdTuples(r_.get());
  return (n && *n) ? std::stoll(n) : 0;
}

int64_t Result::Int(int row, int col) const {
  const char* v = PQgetvalue(r_.get(), row, col);
  switch (PQftype(r_.get(), col)) {
    case kBoolOid:
      return *v != 0;
    case kInt2Oid: {
      uint16_t x;
      std::memcpy(&x, v, 2);
      return static_cast<int16_t>(be16toh(x));
    }
    case kInt4Oid: {
      uint32_t x;
      std::memcpy(&x, v, 4);
      return static_cast<int32_t>(be32toh(x));
    }
    default: {  // int8
      uint64_t x;
      std::memcpy(&x, v, 8);
      return static_cast<int64_t>(be64toh(x));
    }
  }
}

double Result::Real(int row, int col) const {
  const char* v = PQgetvalue(r_.get(), row, col);
  if (PQftype(r_.get(), col) == kFloat4Oid) {
    uint32_t x;
    std::memcpy(&x, v, 4);
    x = be32toh(x);
    float f;
    std::memcpy(&f, &x, 4);
    return f;
  }
  uint64_t x;
  std::memcpy(&x, v, 8);
  x = be64toh(x);
  double d;
  std::memcpy(&d, &x, 8);
  return d;
}

std::string Result::Bytes(int row, int col) const {
  return std::string(PQgetvalue(r_.get(), row, col),
                     static_cast<size_t>(PQgetlength(r_.get(), row, col)));
}

SE3d Result::Pose(int row, int col) const {
  Quatd q(Real(row, col + 3), Real(row, col + 4), Real(row, col + 5), Real(row, col + 6));
  q.normalize();
  return MakeSE3(Vec3d(Real(row, col), Real(row, col + 1), Real(row, col + 2)), q);
}

PinholeCamera Result::Camera(int row, int col) const {
  PinholeCamera c;
  c.fx = Real(row, col);
  c.fy = Real(row, col + 1);
  c.cx = Real(row, col + 2);
  c.cy = Real(row, col + 3);
  c.width_px = static_cast<int>(Int(row, col + 4));
  c.height_px = static_cast<int>(Int(row, col + 5));
  return c;
}

StatusOr<Result> Exec(PGconn* conn, const std::string& sql, const Params& params,
                      const std::string& what) {
  std::vector<const char*> values;
  values.reserve(params.size());
  for (const std::string& v : params.values()) values.push_back(v.data());
  Result r(PQexecParams(conn, sql.c_str(), static_cast<int>(values.size()), params.types(),
                        values.data(), params.lengths(), params.formats(), /*resultFormat=*/1));
  const ExecStatusType st = PQresultStatus(r.get());
  if (st != PGRES_TUPLES_OK && st != PGRES_COMMAND_OK) return ErrorFrom(conn, r.get(), what);
  return r;
}

Status ExecScript(PGconn* conn, const std::string& sql, const std::string& what) {
  std::unique_ptr<PGresult, decltype(&PQclear)> r(PQexec(conn, sql.c_str()), &PQclear);
  const ExecStatusType st = PQresultStatus(r.get());
  if (st != PGRES_TUPLES_OK && st != PGRES_COMMAND_OK) return ErrorFrom(conn, r.get(), what);
  return absl::OkStatus();
}

Transaction::Transaction(PGconn* conn) : conn_(conn), begin_(ExecScript(conn, "BEGIN", "begin")) {
  open_ = begin_.ok();
}

Transaction::~Transaction() {
  if (open_) (void)ExecScript(conn_, "ROLLBACK", "rollback");
}

Status Transaction::Commit() {
  Status s = ExecScript(conn_, "COMMIT", "commit");
  open_ = false;  // a failed COMMIT ends the transaction too (it rolls back)
  return s;
}

}  // namespace loci::server::pg
