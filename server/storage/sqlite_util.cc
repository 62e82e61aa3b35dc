#include "server/storage/sqlite_util.h"

namespace loci::server::sqlite {

Status SqlError(sqlite3* db, const std::string& what) {
  return absl::InternalError(absl::StrCat("sqlite: ", what, ": ", sqlite3_errmsg(db)));
}

Status Exec(sqlite3* db, const std::string& sql) {
  char* err = nullptr;
  if (sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err) != SQLITE_OK) {
    std::string msg = err ? err : "unknown";
    sqlite3_free(err);
    return absl::InternalError(absl::StrCat("sqlite: ", msg));
  }
  return absl::OkStatus();
}

Stmt::Stmt(sqlite3* db, const char* sql) : db_(db) {
  rc_ = sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr);
}

Stmt::~Stmt() { sqlite3_finalize(stmt_); }

Status Stmt::status() const {
  return rc_ == SQLITE_OK ? absl::OkStatus() : SqlError(db_, "prepare");
}

Stmt& Stmt::Bind(int i, int64_t v) {
  sqlite3_bind_int64(stmt_, i, v);
  return *this;
}

Stmt& Stmt::Bind(int i, double v) {
  sqlite3_bind_double(stmt_, i, v);
  return *this;
}

Stmt& Stmt::BindText(int i, const std::string& v) {
  sqlite3_bind_text(stmt_, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT);
  return *this;
}

Stmt& Stmt::BindBlob(int i, const std::string& v) {
  sqlite3_bind_blob(stmt_, i, v.data(), static_cast<int>(v.size()), SQLITE_STATIC);
  return *this;
}

int Stmt::Step() { return sqlite3_step(stmt_); }

void Stmt::Reset() { sqlite3_reset(stmt_); }
int64_t Stmt::Int(int c) const { return sqlite3_column_int64(stmt_, c); }
double Stmt::Real(int c) const { return sqlite3_column_double(stmt_, c); }
bool Stmt::IsNull(int c) const { return sqlite3_column_type(stmt_, c) == SQLITE_NULL; }

std::string Stmt::Text(int c) const {
  const void* p = sqlite3_column_blob(stmt_, c);
  return p ? std::string(static_cast<const char*>(p), sqlite3_column_bytes(stmt_, c))
           : std::string();
}

Transaction::Transaction(sqlite3* db) : db_(db), begin_(Exec(db, "BEGIN IMMEDIATE;")) {
  open_ = begin_.ok();
}

Transaction::~Transaction() {
  if (open_) Exec(db_, "ROLLBACK;").IgnoreError();
}

Status Transaction::Commit() {
  if (!open_) return absl::FailedPreconditionError("sqlite: no open transaction to commit");
  Status s = Exec(db_, "COMMIT;");
  // A failed COMMIT leaves the transaction open: the destructor rolls it back.
  if (s.ok()) open_ = false;
  return s;
}

SE3d PoseFrom(const Stmt& s, int c) {
  return MakeSE3(Vec3d(s.Real(c), s.Real(c + 1), s.Real(c + 2)),
                 Quatd(s.Real(c + 3), s.Real(c + 4), s.Real(c + 5), s.Real(c + 6)));
}

void BindPose(Stmt& s, int i, const SE3d& T) {
  const Quatd q = QuatOf(T);
  s.Bind(i, T.translation().x()).Bind(i + 1, T.translation().y()).Bind(i + 2, T.translation().z());
  s.Bind(i + 3, q.w()).Bind(i + 4, q.x()).Bind(i + 5, q.y()).Bind(i + 6, q.z());
}

PinholeCamera CameraFrom(const Stmt& s, int c) {
  return {s.Real(c),
          s.Real(c + 1),
          s.Real(c + 2),
          s.Real(c + 3),
          static_cast<int>(s.Int(c + 4)),
          static_cast<int>(s.Int(c + 5))};
}

}  // namespace loci::server::sqlite
