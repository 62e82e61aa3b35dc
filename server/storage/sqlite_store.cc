#include "server/storage/sqlite_store.h"

#include <fcntl.h>
#include <sqlite3.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <iterator>
#include <random>
#include <utility>

#include "absl/strings/str_cat.h"
#include "common/time.h"
#include "server/storage/schema_sql.h"
#include "server/storage/sqlite_util.h"

namespace loci::server {
namespace {

// 128 random bits from the OS as 32 hex digits: session ids cannot be guessed (auth.h).
std::string RandomHex128() {
  std::random_device os;  // /dev/urandom on Linux
  std::string hex;
  for (int i = 0; i < 4; ++i) absl::StrAppend(&hex, absl::Hex(os(), absl::kZeroPad8));
  return hex;
}

using sqlite::Exec;
using sqlite::SqlError;
using sqlite::Stmt;
using sqlite::Transaction;
using sqlite::CameraFrom;
using sqlite::BindPose;
using sqlite::PoseFrom;




void BindCamera(Stmt& s, int i, const PinholeCamera& c) {
  s.Bind(i, c.fx).Bind(i + 1, c.fy).Bind(i + 2, c.cx).Bind(i + 3, c.cy);
  s.Bind(i + 4, static_cast<int64_t>(c.width_px)).Bind(i + 5, static_cast<int64_t>(c.height_px));
}

constexpr char kSessionColumns[] =
    "id, session_id, robot_name, client_version, fx, fy, cx, cy, width_px, height_px, "
    "depth_scale, map_tx, map_ty, map_tz, map_qw, map_qx, map_qy, map_qz, opened_ns, closed_ns, "
    "aligned, island_row";

// Creates a missing database file with mode 0600: it holds every camera image. SQLite gives its
// -wal and -shm files the same mode. An existing file keeps its mode.
Status CreatePrivateFile(const std::string& path) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd >= 0) {
    ::close(fd);
  } else if (errno != EEXIST) {
    return absl::UnavailableError(
        absl::StrCat("cannot create database ", path, ": ", std::strerror(errno)));
  }
  return absl::OkStatus();
}

}  // namespace

SqliteStore::SqliteStore(std::string path, SqliteStoreOptions options)
    : path_(std::move(path)),
      options_(options),
      readers_([this] { return OpenConnection(); }, [](sqlite3* db) { sqlite3_close_v2(db); },
               static_cast<size_t>(std::max(0, options.max_idle_readers))) {}

SqliteStore::~SqliteStore() { sqlite3_close_v2(writer_); }

size_t SqliteStore::open_connections() const {
  return readers_.open_count() + (writer_ != nullptr ? 1 : 0);
}

StatusOr<sqlite3*> SqliteStore::Writer() {
  if (options_.read_only) return absl::FailedPreconditionError(path_ + " is open read-only");
  if (writer_ == nullptr) {
    LOCI_ASSIGN_OR_RETURN(writer_, OpenConnection());
  }
  return writer_;
}

int SqliteStore::LatestSchemaVersion() { return static_cast<int>(std::size(kSchemaMigrations)); }

StatusOr<std::unique_ptr<SqliteStore>> SqliteStore::Open(const std::string& path,
                                                         SqliteStoreOptions options) {
  if (options.read_only && !std::filesystem::exists(path)) {
    return absl::NotFoundError(absl::StrCat("database not found: ", path));
  }
  if (!options.read_only) LOCI_RETURN_IF_ERROR(CreatePrivateFile(path));
  std::unique_ptr<SqliteStore> store(new SqliteStore(path, options));
  if (!options.read_only) {
    std::lock_guard<std::mutex> lock(store->write_mu_);
    LOCI_ASSIGN_OR_RETURN(sqlite3 * db, store->Writer());
    LOCI_RETURN_IF_ERROR(store->Migrate(db));
  }
  LOCI_ASSIGN_OR_RETURN(int version, store->SchemaVersion());
  if (version > LatestSchemaVersion()) {
    return absl::FailedPreconditionError(absl::StrCat(path, ": schema version ", version,
                                                      " is newer than this build (",
                                                      LatestSchemaVersion(), ")"));
  }
  return store;
}

StatusOr<sqlite3*> SqliteStore::OpenConnection() const {
  sqlite3* db = nullptr;
  const int flags =
      options_.read_only ? SQLITE_OPEN_READONLY : (SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
  if (sqlite3_open_v2(path_.c_str(), &db, flags | SQLITE_OPEN_NOMUTEX, nullptr) != SQLITE_OK) {
    Status s = absl::UnavailableError(
        absl::StrCat("cannot open database ", path_, ": ", db ? sqlite3_errmsg(db) : "no memory"));
    sqlite3_close_v2(db);
    return s;
  }
  sqlite3_busy_timeout(db, options_.busy_timeout_ms);
  Status s = options_.read_only ? absl::OkStatus()
                                : Exec(db, "PRAGMA journal_mode=WAL; PRAGMA synchronous=NORMAL;");
  if (s.ok()) s = Exec(db, "PRAGMA foreign_keys=ON;");
  if (!s.ok()) {
    sqlite3_close_v2(db);
    return s;
  }
  return db;
}

Status SqliteStore::Migrate(sqlite3* db) {
  Transaction tx(db);
  LOCI_RETURN_IF_ERROR(tx.status());
  Status s =
      Exec(db, "CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);");
  int version = 0;
  if (s.ok()) {
    Stmt q(db, "SELECT value FROM meta WHERE key = 'schema_version'");
    if (q.Step() == SQLITE_ROW) version = std::stoi(q.Text(0));
  }
  for (int v = version; s.ok() && v < LatestSchemaVersion(); ++v) {
    s = Exec(db, kSchemaMigrations[v]);
    if (s.ok()) {
      s = Exec(db,
               absl::StrCat("INSERT OR REPLACE INTO meta(key, value) VALUES('schema_version', '",
                            v + 1, "');"));
    }
  }
  if (!s.ok()) return s;  // rolled back
  return tx.Commit();
}

StatusOr<int> SqliteStore::SchemaVersion() {
  LOCI_ASSIGN_OR_RETURN(auto reader, readers_.Acquire());
  sqlite3* db = reader.get();
  Stmt q(db, "SELECT value FROM meta WHERE key = 'schema_version'");
  if (!q.status().ok()) return 0;  // no meta table: an empty database
  if (q.Step() != SQLITE_ROW) return 0;
  return std::stoi(q.Text(0));
}

StatusOr<SessionRecord> SqliteStore::CreateSession(SessionRecord session) {
  const Status written = Write([&](sqlite3* db) -> Status {
    // The public id carries the row id, which is only known after the insert.
    Stmt ins(db,
             "INSERT INTO sessions(session_id, robot_name, client_version, fx, fy, cx, cy,"
             " width_px, height_px, depth_scale, map_tx, map_ty, map_tz, map_qw, map_qx, map_qy,"
             " map_qz, opened_ns, aligned) VALUES(lower(hex(randomblob(8))), ?,?,?,?,?,?,?,?,?,?,?,?,?,"
             "?,?,?,?,?)");
    LOCI_RETURN_IF_ERROR(ins.status());
    ins.BindText(1, session.robot_name).BindText(2, session.client_version);
    BindCamera(ins, 3, session.camera);
    ins.Bind(9, session.depth_scale);
    BindPose(ins, 10, session.T_base_odom);
    ins.Bind(17, session.opened_ns);
    ins.Bind(18, static_cast<int64_t>(session.aligned ? 1 : 0));
    if (ins.Step() != SQLITE_DONE) return SqlError(db, "insert session");
    session.row_id = sqlite3_last_insert_rowid(db);
    session.session_id =
        absl::StrCat(session.robot_name, "-", session.row_id, "-", RandomHex128());
    Stmt upd(db, "UPDATE sessions SET session_id = ? WHERE id = ?");
    upd.BindText(1, session.session_id).Bind(2, session.row_id);
    if (upd.Step() != SQLITE_DONE) return SqlError(db, "update session");
    return absl::OkStatus();
  });
  if (!written.ok()) return written;
  session.open = true;
  return session;
}

StatusOr<std::vector<SessionRecord>> SqliteStore::QuerySessions(const std::string& where_sql,
                                                                const std::string& arg) {
  LOCI_ASSIGN_OR_RETURN(auto reader, readers_.Acquire());
  sqlite3* db = reader.get();
  const std::string sql = absl::StrCat("SELECT ", kSessionColumns, " FROM sessions ", where_sql);
  Stmt q(db, sql.c_str());
  LOCI_RETURN_IF_ERROR(q.status());
  if (!arg.empty()) q.BindText(1, arg);
  std::vector<SessionRecord> out;
  int rc;
  while ((rc = q.Step()) == SQLITE_ROW) {
    SessionRecord s;
    s.row_id = q.Int(0);
    s.session_id = q.Text(1);
    s.robot_name = q.Text(2);
    s.client_version = q.Text(3);
    s.camera = CameraFrom(q, 4);
    s.depth_scale = q.Real(10);
    s.T_base_odom = PoseFrom(q, 11);
    s.opened_ns = q.Int(18);
    s.open = q.IsNull(19);
    s.aligned = q.Int(20) != 0;
    if (!s.aligned && !q.IsNull(21)) {  // joined another session's island
      s.island_row = q.Int(21);
      s.T_island_odom = s.T_base_odom;
      s.T_base_odom = SE3d::Identity();
    }
    out.push_back(std::move(s));
  }
  if (rc != SQLITE_DONE) return SqlError(db, "query sessions");
  return out;
}

StatusOr<std::optional<SessionRecord>> SqliteStore::LatestOpenSession(
    const std::string& robot_name) {
  LOCI_ASSIGN_OR_RETURN(
      auto rows,
      QuerySessions("WHERE robot_name = ? AND closed_ns IS NULL ORDER BY id DESC LIMIT 1",
                    robot_name));
  if (rows.empty()) return std::optional<SessionRecord>();
  return std::optional<SessionRecord>(std::move(rows[0]));
}

StatusOr<std::optional<SessionRecord>> SqliteStore::FindSession(const std::string& session_id) {
  if (session_id.empty()) return std::optional<SessionRecord>();
  LOCI_ASSIGN_OR_RETURN(auto rows, QuerySessions("WHERE session_id = ?", session_id));
  if (rows.empty()) return std::optional<SessionRecord>();
  return std::optional<SessionRecord>(std::move(rows[0]));
}

StatusOr<std::vector<SessionRecord>> SqliteStore::ListSessions() {
  return QuerySessions("ORDER BY id", "");
}

Status SqliteStore::CloseSession(int64_t session_row, int64_t closed_ns) {
  std::lock_guard<std::mutex> lock(write_mu_);
  LOCI_ASSIGN_OR_RETURN(sqlite3 * db, Writer());
  Stmt q(db, "UPDATE sessions SET closed_ns = ? WHERE id = ?");
  LOCI_RETURN_IF_ERROR(q.status());
  q.Bind(1, closed_ns).Bind(2, session_row);
  if (q.Step() != SQLITE_DONE) return SqlError(db, "close session");
  return absl::OkStatus();
}

Status SqliteStore::SetSessionAlignment(int64_t session_row, const SE3d& T_base_odom) {
  return Write([&](sqlite3* db) -> Status {
    Stmt q(db,
           "UPDATE sessions SET map_tx = ?, map_ty = ?, map_tz = ?, map_qw = ?, map_qx = ?,"
           " map_qy = ?, map_qz = ?, aligned = 1 WHERE id = ?");
    LOCI_RETURN_IF_ERROR(q.status());
    BindPose(q, 1, T_base_odom);
    q.Bind(8, session_row);
    if (q.Step() != SQLITE_DONE) return SqlError(db, "align session");
    if (sqlite3_changes(db) != 1) {
      return absl::NotFoundError(absl::StrCat("no session row ", session_row));
    }
    return absl::OkStatus();
  });
}

Status SqliteStore::SetSessionIsland(int64_t session_row, int64_t island_row,
                                     const SE3d& T_island_odom) {
  return Write([&](sqlite3* db) -> Status {
    Stmt q(db,
           "UPDATE sessions SET map_tx = ?, map_ty = ?, map_tz = ?, map_qw = ?, map_qx = ?,"
           " map_qy = ?, map_qz = ?, island_row = ? WHERE id = ? AND aligned = 0");
    LOCI_RETURN_IF_ERROR(q.status());
    BindPose(q, 1, T_island_odom);
    q.Bind(8, island_row).Bind(9, session_row);
    if (q.Step() != SQLITE_DONE) return SqlError(db, "join island");
    if (sqlite3_changes(db) != 1) {
      return absl::NotFoundError(absl::StrCat("no unaligned session row ", session_row));
    }
    return absl::OkStatus();
  });
}

StatusOr<InsertResult> SqliteStore::InsertKeyframe(const KeyframeRecord& kf) {
  FrameDetections frame;
  frame.t_ns = kf.t_ns;
  frame.detections = kf.detections;
  const std::string detections_json = DetectionsToJsonLine(frame);
  std::lock_guard<std::mutex> lock(write_mu_);
  LOCI_ASSIGN_OR_RETURN(sqlite3 * db, Writer());
  Transaction tx(db);
  LOCI_RETURN_IF_ERROR(tx.status());
  auto fail = [db](const std::string& what) { return SqlError(db, what); };  // rolls back
  InsertResult result;
  {
    Stmt ins(db,
             "INSERT OR IGNORE INTO keyframes(session, seq, t_ns, tx, ty, tz, qw, qx, qy, qz, fx,"
             " fy, cx, cy, width_px, height_px, depth_scale, has_gravity, gx, gy, gz, segment,"
             " rgb_jpeg, depth_png, detections, stored_ns, tracking_inliers)"
             " VALUES(?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?)");
    if (!ins.status().ok()) return fail("prepare insert keyframe");
    ins.Bind(1, kf.session_row).Bind(2, kf.seq).Bind(3, kf.t_ns);
    BindPose(ins, 4, kf.T_odom_cam);
    BindCamera(ins, 11, kf.camera);
    ins.Bind(17, kf.depth_scale).Bind(18, static_cast<int64_t>(kf.has_gravity));
    ins.Bind(19, kf.gravity_cam.x()).Bind(20, kf.gravity_cam.y()).Bind(21, kf.gravity_cam.z());
    ins.Bind(22, static_cast<int64_t>(kf.segment));
    ins.BindBlob(23, kf.rgb_jpeg).BindBlob(24, kf.depth_png).BindText(25, detections_json);
    ins.Bind(26, NowNs()).Bind(27, static_cast<int64_t>(kf.tracking_inliers));
    if (ins.Step() != SQLITE_DONE) return fail("insert keyframe");
  }
  if (sqlite3_changes(db) == 1) {
    result.keyframe_id = sqlite3_last_insert_rowid(db);
  } else {
    result.duplicate = true;
    Stmt q(db,
           "SELECT id, t_ns = ? AND tx = ? AND ty = ? AND tz = ? AND qw = ? AND qx = ? AND"
           " qy = ? AND qz = ? AND ((rgb_jpeg = ? AND depth_png = ?) OR length(rgb_jpeg) = 0)"
           " FROM keyframes WHERE session = ? AND seq = ?");
    q.Bind(1, kf.t_ns);
    BindPose(q, 2, kf.T_odom_cam);
    q.BindBlob(9, kf.rgb_jpeg).BindBlob(10, kf.depth_png);
    q.Bind(11, kf.session_row).Bind(12, kf.seq);
    if (q.Step() != SQLITE_ROW) return fail("find duplicate keyframe");
    result.keyframe_id = q.Int(0);
    result.conflict = q.Int(1) == 0;
  }
  LOCI_RETURN_IF_ERROR(tx.Commit());
  return result;
}

StatusOr<int64_t> SqliteStore::LastStoredSeq(int64_t session_row) {
  LOCI_ASSIGN_OR_RETURN(auto reader, readers_.Acquire());
  sqlite3* db = reader.get();
  Stmt q(db, "SELECT MAX(seq) FROM keyframes WHERE session = ?");
  LOCI_RETURN_IF_ERROR(q.status());
  q.Bind(1, session_row);
  if (q.Step() != SQLITE_ROW) return SqlError(db, "last seq");
  return q.IsNull(0) ? int64_t{-1} : q.Int(0);
}

StatusOr<LastStamp> SqliteStore::LastStoredStamp(int64_t session_row) {
  LOCI_ASSIGN_OR_RETURN(auto reader, readers_.Acquire());
  sqlite3* db = reader.get();
  Stmt q(db, "SELECT seq, t_ns FROM keyframes WHERE session = ? ORDER BY seq DESC LIMIT 1");
  LOCI_RETURN_IF_ERROR(q.status());
  q.Bind(1, session_row);
  LastStamp last;
  const int rc = q.Step();
  if (rc == SQLITE_ROW) {
    last.seq = q.Int(0);
    last.t_ns = q.Int(1);
  } else if (rc != SQLITE_DONE) {
    return SqlError(db, "last stamp");
  }
  return last;
}

StatusOr<uint64_t> SqliteStore::CountKeyframes(std::optional<int64_t> session_row) {
  LOCI_ASSIGN_OR_RETURN(auto reader, readers_.Acquire());
  sqlite3* db = reader.get();
  Stmt q(db, session_row ? "SELECT COUNT(*) FROM keyframes WHERE session = ?"
                         : "SELECT COUNT(*) FROM keyframes");
  LOCI_RETURN_IF_ERROR(q.status());
  if (session_row) q.Bind(1, *session_row);
  if (q.Step() != SQLITE_ROW) return SqlError(db, "count keyframes");
  return static_cast<uint64_t>(q.Int(0));
}

uint64_t SqliteStore::DbBytes() {
  uint64_t bytes = 0;
  for (const char* suffix : {"", "-wal"}) {
    std::error_code ec;
    const auto n = std::filesystem::file_size(path_ + suffix, ec);
    if (!ec) bytes += n;
  }
  return bytes;
}

}  // namespace loci::server
