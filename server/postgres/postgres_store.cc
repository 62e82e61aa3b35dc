#include "server/postgres/postgres_store.h"

#include <algorithm>
#include <iterator>
#include <random>
#include <regex>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "common/detections_io.h"
#include "common/time.h"
#include "server/postgres/pg_schema_sql.h"
#include "server/postgres/pg_util.h"

namespace loci::server {
namespace {

using pg::Exec;
using pg::ExecScript;
using pg::Params;
using pg::Result;

// 128 random bits from the OS as 32 hex digits: session ids cannot be guessed (auth.h).
std::string RandomHex128() {
  std::random_device os;
  std::string hex;
  for (int i = 0; i < 4; ++i) absl::StrAppend(&hex, absl::Hex(os(), absl::kZeroPad8));
  return hex;
}

constexpr char kSessionColumns[] =
    "id, session_id, robot_name, client_version, fx, fy, cx, cy, width_px, height_px, "
    "depth_scale, map_tx, map_ty, map_tz, map_qw, map_qx, map_qy, map_qz, opened_ns, closed_ns, "
    "aligned, island_row";

SessionRecord SessionFrom(const Result& r, int row) {
  SessionRecord s;
  s.row_id = r.Int(row, 0);
  s.session_id = r.Bytes(row, 1);
  s.robot_name = r.Bytes(row, 2);
  s.client_version = r.Bytes(row, 3);
  s.camera = r.Camera(row, 4);
  s.depth_scale = r.Real(row, 10);
  s.T_base_odom = r.Pose(row, 11);
  s.opened_ns = r.Int(row, 18);
  s.open = r.IsNull(row, 19);
  s.aligned = r.Bool(row, 20);
  if (!s.aligned && !r.IsNull(row, 21)) {  // joined another session's island
    s.island_row = r.Int(row, 21);
    s.T_island_odom = s.T_base_odom;
    s.T_base_odom = SE3d::Identity();
  }
  return s;
}

// Applies the migrations after `version` of `migrations`, recording each in `meta_table`.
Status MigrateSchema(PGconn* conn, const char* const* migrations, int count,
                     const std::string& meta_table) {
  LOCI_RETURN_IF_ERROR(ExecScript(
      conn,
      absl::StrCat("CREATE TABLE IF NOT EXISTS ", meta_table,
                   " (key TEXT PRIMARY KEY, value TEXT NOT NULL)"),
      "create " + meta_table));
  LOCI_ASSIGN_OR_RETURN(
      Result v, Exec(conn, absl::StrCat("SELECT value FROM ", meta_table,
                                        " WHERE key = 'schema_version'"),
                     Params(), "read schema version"));
  int version = v.rows() > 0 ? std::stoi(v.Bytes(0, 0)) : 0;
  for (; version < count; ++version) {
    LOCI_RETURN_IF_ERROR(ExecScript(conn, migrations[version],
                                    absl::StrCat("migrate ", meta_table, " to ", version + 1)));
    LOCI_RETURN_IF_ERROR(
        Exec(conn,
             absl::StrCat("INSERT INTO ", meta_table,
                          "(key, value) VALUES('schema_version', $1) ON CONFLICT (key) DO "
                          "UPDATE SET value = EXCLUDED.value"),
             Params().Text(std::to_string(version + 1)), "record schema version")
            .status());
  }
  return absl::OkStatus();
}

}  // namespace

PostgresStore::PostgresStore(std::string uri, std::string schema, PostgresStoreOptions options)
    : uri_(std::move(uri)),
      schema_(std::move(schema)),
      options_(std::move(options)),
      readers_([this] { return OpenConnection(); }, [](PGconn* c) { PQfinish(c); },
               static_cast<size_t>(std::max(0, options_.max_idle_readers))) {}

PostgresStore::~PostgresStore() {
  if (writer_ != nullptr) PQfinish(writer_);
  if (listener_ != nullptr) PQfinish(listener_);
}

int PostgresStore::LatestSchemaVersion() {
  return static_cast<int>(std::size(pg::kSiteMigrations));
}

StatusOr<std::string> PostgresStore::SchemaOfSite(const std::string& site) {
  static const std::regex kSite("[a-z0-9][a-z0-9_-]{0,39}");
  if (!std::regex_match(site, kSite)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "site name '", site, "': use 1 to 40 of a-z, 0-9, '_' and '-', starting with a letter "
        "or digit"));
  }
  return absl::StrCat("site_", absl::StrReplaceAll(site, {{"-", "_"}}));
}

Status PostgresStore::DropSite(const std::string& uri, const std::string& site) {
  LOCI_ASSIGN_OR_RETURN(std::string schema, SchemaOfSite(site));
  LOCI_ASSIGN_OR_RETURN(PGconn * conn, pg::Connect(uri, ""));
  Status s;
  {
    pg::Transaction tx(conn);
    s = tx.status();
    if (s.ok()) {
      s = ExecScript(conn, absl::StrCat("DROP SCHEMA IF EXISTS ", schema, " CASCADE"),
                     "drop site schema");
    }
    for (const char* table : {"public.loci_site_leases", "public.loci_sites"}) {
      if (s.ok()) {
        s = Exec(conn, absl::StrCat("DELETE FROM ", table, " WHERE site = $1"),
                 Params().Text(site), "forget the site")
                .status();
      }
    }
    if (s.ok()) s = tx.Commit();
  }
  PQfinish(conn);
  return s;
}

size_t PostgresStore::open_connections() const {
  return readers_.open_count() + (writer_ != nullptr ? 1 : 0);
}

StatusOr<std::unique_ptr<PostgresStore>> PostgresStore::Open(const std::string& uri,
                                                             PostgresStoreOptions options) {
  LOCI_ASSIGN_OR_RETURN(std::string schema, SchemaOfSite(options.site));
  std::unique_ptr<PostgresStore> store(new PostgresStore(uri, schema, options));
  if (!options.read_only) {
    LOCI_ASSIGN_OR_RETURN(PGconn * conn, pg::Connect(uri, ""));
    const Status migrated = store->Migrate(conn);
    PQfinish(conn);
    LOCI_RETURN_IF_ERROR(migrated);
  }
  LOCI_ASSIGN_OR_RETURN(int version, store->SchemaVersion());
  if (version == 0) {
    return absl::NotFoundError(absl::StrCat("site '", options.site, "' has no map in ", uri));
  }
  if (version > LatestSchemaVersion()) {
    return absl::FailedPreconditionError(
        absl::StrCat("site '", options.site, "': schema version ", version,
                     " is newer than this build (", LatestSchemaVersion(), ")"));
  }
  return store;
}

Status PostgresStore::Migrate(PGconn* conn) {
  pg::Transaction tx(conn);
  LOCI_RETURN_IF_ERROR(tx.status());
  // DDL is transactional; the lock makes servers that start at once migrate one after another.
  LOCI_RETURN_IF_ERROR(ExecScript(conn, "SELECT pg_advisory_xact_lock(4711001)", "lock"));
  Status fleet = MigrateSchema(conn, pg::kFleetMigrations,
                               static_cast<int>(std::size(pg::kFleetMigrations)),
                               "public.loci_meta");
  if (!fleet.ok()) {
    return absl::Status(fleet.code(),
                        absl::StrCat(fleet.message(),
                                     " (PostGIS must be installed on the database server: "
                                     "Debian's postgresql-15-postgis-3; CREATE EXTENSION needs a "
                                     "role allowed to create it)"));
  }
  LOCI_RETURN_IF_ERROR(
      Exec(conn,
           "INSERT INTO public.loci_sites(site, schema_name, created_ns) VALUES($1, $2, $3)"
           " ON CONFLICT (site) DO NOTHING",
           Params().Text(options_.site).Text(schema_).Int(NowNs()), "register site")
          .status());
  LOCI_RETURN_IF_ERROR(
      ExecScript(conn, absl::StrCat("CREATE SCHEMA IF NOT EXISTS ", schema_), "create schema"));
  LOCI_RETURN_IF_ERROR(ExecScript(
      conn, absl::StrCat("SET LOCAL search_path TO ", schema_, ", public"), "search path"));
  LOCI_RETURN_IF_ERROR(MigrateSchema(conn, pg::kSiteMigrations, LatestSchemaVersion(),
                                     absl::StrCat(schema_, ".meta")));
  return tx.Commit();
}

StatusOr<PGconn*> PostgresStore::OpenConnection() const { return pg::Connect(uri_, schema_); }

StatusOr<PGconn*> PostgresStore::Writer() {
  if (options_.read_only) {
    return absl::FailedPreconditionError(
        absl::StrCat("site '", options_.site, "' is open read-only"));
  }
  if (writer_ != nullptr && !pg::Healthy(writer_)) {  // the server restarted: connect again
    PQfinish(writer_);
    writer_ = nullptr;
  }
  if (writer_ == nullptr) {
    LOCI_ASSIGN_OR_RETURN(writer_, OpenConnection());
  }
  return writer_;
}

void PostgresStore::SetFence(std::optional<SiteFence> fence) {
  std::lock_guard<std::mutex> lock(write_mu_);
  fence_ = std::move(fence);
}

Status PostgresStore::CheckFence(PGconn* conn) {
  if (!fence_) return absl::OkStatus();
  LOCI_ASSIGN_OR_RETURN(
      Result r, Exec(conn,
                     "SELECT 1 FROM public.loci_site_leases WHERE site = $1 AND holder = $2"
                     " AND epoch = $3 AND expires_at > now() FOR SHARE",
                     Params().Text(options_.site).Text(fence_->holder).Int(fence_->epoch),
                     "check the site lease"));
  if (r.rows() == 0) {
    return absl::FailedPreconditionError(absl::StrCat(
        "site '", options_.site, "': this server no longer holds the writer lease (epoch ",
        fence_->epoch, "); nothing was written"));
  }
  return absl::OkStatus();
}

Status PostgresStore::Write(const std::function<Status(PGconn*)>& body) {
  std::lock_guard<std::mutex> lock(write_mu_);
  LOCI_ASSIGN_OR_RETURN(PGconn * conn, Writer());
  pg::Transaction tx(conn);
  LOCI_RETURN_IF_ERROR(tx.status());
  LOCI_RETURN_IF_ERROR(CheckFence(conn));
  LOCI_RETURN_IF_ERROR(body(conn));
  return tx.Commit();
}

Status PostgresStore::Read(const std::function<Status(PGconn*)>& body) {
  LOCI_ASSIGN_OR_RETURN(auto reader, readers_.Acquire());
  Status s = body(reader.get());
  if (!pg::Healthy(reader.get())) reader.Discard();
  return s;
}

StatusOr<int> PostgresStore::SchemaVersion() {
  int version = 0;
  LOCI_RETURN_IF_ERROR(Read([&](PGconn* c) -> Status {
    LOCI_ASSIGN_OR_RETURN(Result has, Exec(c, "SELECT to_regclass($1) IS NOT NULL",
                                           Params().Text(schema_ + ".meta"), "find meta"));
    if (!has.Bool(0, 0)) return absl::OkStatus();
    LOCI_ASSIGN_OR_RETURN(Result r, Exec(c, "SELECT value FROM meta WHERE key = 'schema_version'",
                                         Params(), "read schema version"));
    if (r.rows() > 0) version = std::stoi(r.Bytes(0, 0));
    return absl::OkStatus();
  }));
  return version;
}

StatusOr<SessionRecord> PostgresStore::CreateSession(SessionRecord session) {
  LOCI_RETURN_IF_ERROR(Write([&](PGconn* c) -> Status {
    LOCI_ASSIGN_OR_RETURN(
        Result r,
        Exec(c,
             "INSERT INTO sessions(session_id, robot_name, client_version, fx, fy, cx, cy,"
             " width_px, height_px, depth_scale, map_tx, map_ty, map_tz, map_qw, map_qx, map_qy,"
             " map_qz, opened_ns, aligned) VALUES(md5(random()::text), $1, $2, $3, $4, $5, $6,"
             " $7, $8, $9, $10, $11, $12, $13, $14, $15, $16, $17, $18) RETURNING id",
             Params()
                 .Text(session.robot_name)
                 .Text(session.client_version)
                 .Camera(session.camera)
                 .Real(session.depth_scale)
                 .Pose(session.T_base_odom)
                 .Int(session.opened_ns)
                 .Bool(session.aligned),
             "insert session"));
    session.row_id = r.Int(0, 0);
    // The public id carries the row id, which is only known after the insert.
    session.session_id =
        absl::StrCat(session.robot_name, "-", session.row_id, "-", RandomHex128());
    return Exec(c, "UPDATE sessions SET session_id = $1 WHERE id = $2",
                Params().Text(session.session_id).Int(session.row_id), "name session")
        .status();
  }));
  session.open = true;
  return session;
}

StatusOr<std::vector<SessionRecord>> PostgresStore::QuerySessions(const std::string& where_sql,
                                                                  const std::string& arg) {
  std::vector<SessionRecord> out;
  LOCI_RETURN_IF_ERROR(Read([&](PGconn* c) -> Status {
    Params p;
    if (!arg.empty()) p.Text(arg);
    LOCI_ASSIGN_OR_RETURN(
        Result r, Exec(c, absl::StrCat("SELECT ", kSessionColumns, " FROM sessions ", where_sql),
                       p, "query sessions"));
    for (int i = 0; i < r.rows(); ++i) out.push_back(SessionFrom(r, i));
    return absl::OkStatus();
  }));
  return out;
}

StatusOr<std::optional<SessionRecord>> PostgresStore::LatestOpenSession(
    const std::string& robot_name) {
  LOCI_ASSIGN_OR_RETURN(
      auto rows,
      QuerySessions("WHERE robot_name = $1 AND closed_ns IS NULL ORDER BY id DESC LIMIT 1",
                    robot_name));
  if (rows.empty()) return std::optional<SessionRecord>();
  return std::optional<SessionRecord>(std::move(rows[0]));
}

StatusOr<std::optional<SessionRecord>> PostgresStore::FindSession(const std::string& session_id) {
  if (session_id.empty()) return std::optional<SessionRecord>();
  LOCI_ASSIGN_OR_RETURN(auto rows, QuerySessions("WHERE session_id = $1", session_id));
  if (rows.empty()) return std::optional<SessionRecord>();
  return std::optional<SessionRecord>(std::move(rows[0]));
}

StatusOr<std::vector<SessionRecord>> PostgresStore::ListSessions() {
  return QuerySessions("ORDER BY id", "");
}

Status PostgresStore::CloseSession(int64_t session_row, int64_t closed_ns) {
  return Write([&](PGconn* c) {
    return Exec(c, "UPDATE sessions SET closed_ns = $1 WHERE id = $2",
                Params().Int(closed_ns).Int(session_row), "close session")
        .status();
  });
}

Status PostgresStore::SetSessionAlignment(int64_t session_row, const SE3d& T_base_odom) {
  return Write([&](PGconn* c) -> Status {
    LOCI_ASSIGN_OR_RETURN(
        Result r, Exec(c,
                       "UPDATE sessions SET map_tx = $1, map_ty = $2, map_tz = $3, map_qw = $4,"
                       " map_qx = $5, map_qy = $6, map_qz = $7, aligned = TRUE WHERE id = $8",
                       Params().Pose(T_base_odom).Int(session_row), "align session"));
    if (r.affected() != 1) return absl::NotFoundError(absl::StrCat("no session row ", session_row));
    return absl::OkStatus();
  });
}

Status PostgresStore::SetSessionIsland(int64_t session_row, int64_t island_row,
                                       const SE3d& T_island_odom) {
  return Write([&](PGconn* c) -> Status {
    LOCI_ASSIGN_OR_RETURN(
        Result r,
        Exec(c,
             "UPDATE sessions SET map_tx = $1, map_ty = $2, map_tz = $3, map_qw = $4,"
             " map_qx = $5, map_qy = $6, map_qz = $7, island_row = $8 WHERE id = $9"
             " AND NOT aligned",
             Params().Pose(T_island_odom).Int(island_row).Int(session_row), "join island"));
    if (r.affected() != 1) {
      return absl::NotFoundError(absl::StrCat("no unaligned session row ", session_row));
    }
    return absl::OkStatus();
  });
}

StatusOr<int64_t> PostgresStore::InsertKeyframeRow(PGconn* conn, const KeyframeRecord& kf,
                                                  bool keep_id, int64_t stored_ns) {
  FrameDetections frame;
  frame.t_ns = kf.t_ns;
  frame.detections = kf.detections;
  Params p;
  if (keep_id) p.Int(kf.id);
  p.Int(kf.session_row)
      .Int(kf.seq)
      .Int(kf.t_ns)
      .Pose(kf.T_odom_cam)
      .Camera(kf.camera)
      .Real(kf.depth_scale)
      .Bool(kf.has_gravity)
      .Real(kf.gravity_cam.x())
      .Real(kf.gravity_cam.y())
      .Real(kf.gravity_cam.z())
      .Int(kf.segment)
      .Int(kf.tracking_inliers)
      .Bytes(kf.rgb_jpeg)
      .Bytes(kf.depth_png)
      .Text(DetectionsToJsonLine(frame))
      .Int(stored_ns);
  std::string values;
  for (size_t i = 1; i <= p.size(); ++i) absl::StrAppend(&values, "$", i, ", ");
  const int tx = keep_id ? 5 : 4;  // the parameter of T_odom_cam's x
  LOCI_ASSIGN_OR_RETURN(
      Result r,
      Exec(conn,
           absl::StrCat("INSERT INTO keyframes(", keep_id ? "id, " : "",
                        "session, seq, t_ns, tx, ty, tz, qw, qx, qy, qz, fx, fy, cx, cy,"
                        " width_px, height_px, depth_scale, has_gravity, gx, gy, gz, segment,"
                        " tracking_inliers, rgb_jpeg, depth_png, detections, stored_ns,"
                        " position_odom) VALUES(",
                        values, "ST_MakePoint($", tx, ", $", tx + 1, ", $", tx + 2,
                        ")) RETURNING id"),
           p, absl::StrCat("insert keyframe ", kf.session_row, ":", kf.seq)));
  return r.Int(0, 0);
}

StatusOr<InsertResult> PostgresStore::InsertKeyframe(const KeyframeRecord& kf) {
  InsertResult result;
  LOCI_RETURN_IF_ERROR(Write([&](PGconn* c) -> Status {
    // A duplicate is looked up first (one writer per site), so it takes no id from the sequence.
    LOCI_ASSIGN_OR_RETURN(
        Result dup,
        Exec(c,
             "SELECT id, t_ns = $3 AND tx = $4 AND ty = $5 AND tz = $6 AND qw = $7 AND qx = $8"
             " AND qy = $9 AND qz = $10 AND ((rgb_jpeg = $11 AND depth_png = $12)"
             " OR octet_length(rgb_jpeg) = 0) FROM keyframes WHERE session = $1 AND seq = $2",
             Params()
                 .Int(kf.session_row)
                 .Int(kf.seq)
                 .Int(kf.t_ns)
                 .Pose(kf.T_odom_cam)
                 .Bytes(kf.rgb_jpeg)
                 .Bytes(kf.depth_png),
             "find duplicate keyframe"));
    if (dup.rows() > 0) {
      result.duplicate = true;
      result.keyframe_id = dup.Int(0, 0);
      result.conflict = !dup.Bool(0, 1);
      return absl::OkStatus();
    }
    LOCI_ASSIGN_OR_RETURN(result.keyframe_id, InsertKeyframeRow(c, kf, false, NowNs()));
    return absl::OkStatus();
  }));
  return result;
}

StatusOr<int64_t> PostgresStore::LastStoredSeq(int64_t session_row) {
  LOCI_ASSIGN_OR_RETURN(LastStamp last, LastStoredStamp(session_row));
  return last.seq;
}

StatusOr<LastStamp> PostgresStore::LastStoredStamp(int64_t session_row) {
  LastStamp last;
  LOCI_RETURN_IF_ERROR(Read([&](PGconn* c) -> Status {
    LOCI_ASSIGN_OR_RETURN(
        Result r, Exec(c, "SELECT seq, t_ns FROM keyframes WHERE session = $1"
                          " ORDER BY seq DESC LIMIT 1",
                       Params().Int(session_row), "last stamp"));
    if (r.rows() > 0) last = LastStamp{r.Int(0, 0), r.Int(0, 1)};
    return absl::OkStatus();
  }));
  return last;
}

StatusOr<uint64_t> PostgresStore::CountKeyframes(std::optional<int64_t> session_row) {
  uint64_t n = 0;
  LOCI_RETURN_IF_ERROR(Read([&](PGconn* c) -> Status {
    Params p;
    if (session_row) p.Int(*session_row);
    LOCI_ASSIGN_OR_RETURN(Result r, Exec(c,
                                         session_row
                                             ? "SELECT COUNT(*) FROM keyframes WHERE session = $1"
                                             : "SELECT COUNT(*) FROM keyframes",
                                         p, "count keyframes"));
    n = static_cast<uint64_t>(r.Int(0, 0));
    return absl::OkStatus();
  }));
  return n;
}

}  // namespace loci::server
