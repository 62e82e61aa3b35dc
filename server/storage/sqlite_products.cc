// SqliteStore: the keyframe scan, per-keyframe products, checkpoints, retention and sizes
// (schema/002_products_checkpoints.sql) and corrected poses (003_keyframe_poses.sql).
#include <sqlite3.h>

#include "common/detections_io.h"
#include "common/time.h"
#include "server/storage/sqlite_store.h"
#include "server/storage/sqlite_util.h"

namespace loci::server {

using sqlite::BindPose;
using sqlite::CameraFrom;
using sqlite::PoseFrom;
using sqlite::SqlError;
using sqlite::Stmt;
using sqlite::Transaction;

namespace {

std::string ScanSql(const KeyframeScan& scan) {
  const bool products = !scan.products_fingerprint.empty();
  const char* images = !scan.images ? "NULL, NULL, NULL"
                       : products   ? "CASE WHEN p.data IS NULL THEN k.rgb_jpeg END,"
                                      " CASE WHEN p.data IS NULL THEN k.depth_png END,"
                                      " CASE WHEN p.data IS NULL THEN k.detections END"
                                    : "k.rgb_jpeg, k.depth_png, k.detections";
  return absl::StrCat(
      "SELECT k.id, k.session, k.seq, k.t_ns, k.tx, k.ty, k.tz, k.qw, k.qx, k.qy, k.qz, k.fx,"
      " k.fy, k.cx, k.cy, k.width_px, k.height_px, k.depth_scale, k.has_gravity, k.gx, k.gy,"
      " k.gz, k.segment, ",
      images, ", ", products ? "p.data" : "NULL",
      ", c.tx, c.ty, c.tz, c.qw, c.qx, c.qy, c.qz, k.tracking_inliers FROM keyframes k",
      " LEFT JOIN keyframe_poses c ON c.keyframe_id = k.id",
      products ? " LEFT JOIN keyframe_products p ON p.keyframe_id = k.id AND p.fingerprint = ?2"
               : "",
      " WHERE k.id > ?1", scan.session_row ? " AND k.session = ?3" : "",
      scan.last_id ? " AND k.id <= ?4" : "", " ORDER BY k.id");
}

StatusOr<KeyframeRecord> RecordFrom(const Stmt& q) {
  KeyframeRecord kf;
  kf.id = q.Int(0);
  kf.session_row = q.Int(1);
  kf.seq = q.Int(2);
  kf.t_ns = q.Int(3);
  kf.T_odom_cam = PoseFrom(q, 4);
  kf.camera = CameraFrom(q, 11);
  kf.depth_scale = q.Real(17);
  kf.has_gravity = q.Int(18) != 0;
  kf.gravity_cam = Vec3d(q.Real(19), q.Real(20), q.Real(21));
  kf.segment = static_cast<int>(q.Int(22));
  if (!q.IsNull(23)) kf.rgb_jpeg = q.Text(23);
  if (!q.IsNull(24)) kf.depth_png = q.Text(24);
  if (!q.IsNull(25)) {
    LOCI_ASSIGN_OR_RETURN(FrameDetections dets, DetectionsFromJsonLine(q.Text(25)));
    kf.detections = std::move(dets.detections);
  }
  if (!q.IsNull(26)) kf.products = q.Text(26);
  if (!q.IsNull(27)) kf.T_base_kf_corrected = PoseFrom(q, 27);
  kf.tracking_inliers = static_cast<int>(q.Int(34));
  return kf;
}

}  // namespace

Status SqliteStore::ForEachKeyframe(int64_t after_id,
                                    const std::function<Status(KeyframeRecord)>& fn,
                                    const KeyframeScan& scan) {
  LOCI_ASSIGN_OR_RETURN(auto reader, readers_.Acquire());
  sqlite3* db = reader.get();
  const std::string sql = ScanSql(scan);
  Stmt q(db, sql.c_str());
  LOCI_RETURN_IF_ERROR(q.status());
  q.Bind(1, after_id);
  if (!scan.products_fingerprint.empty()) q.BindText(2, scan.products_fingerprint);
  if (scan.session_row) q.Bind(3, *scan.session_row);
  if (scan.last_id) q.Bind(4, *scan.last_id);
  int rc;
  while ((rc = q.Step()) == SQLITE_ROW) {
    LOCI_ASSIGN_OR_RETURN(KeyframeRecord kf, RecordFrom(q));
    LOCI_RETURN_IF_ERROR(fn(std::move(kf)));
  }
  if (rc != SQLITE_DONE) return SqlError(db, "read keyframes");
  return absl::OkStatus();
}

Status SqliteStore::Write(const std::function<Status(sqlite3*)>& body) {
  std::lock_guard<std::mutex> lock(write_mu_);
  LOCI_ASSIGN_OR_RETURN(sqlite3 * db, Writer());
  Transaction tx(db);
  LOCI_RETURN_IF_ERROR(tx.status());
  LOCI_RETURN_IF_ERROR(body(db));
  return tx.Commit();
}

Status SqliteStore::WriteOne(const char* sql, const std::function<void(Stmt&)>& bind,
                             const char* what) {
  return Write([&](sqlite3* db) -> Status {
    Stmt s(db, sql);
    if (!s.status().ok()) return SqlError(db, absl::StrCat("prepare ", what));
    bind(s);
    if (s.Step() != SQLITE_DONE) return SqlError(db, what);
    return absl::OkStatus();
  });
}

Status SqliteStore::PutProducts(int64_t keyframe_id, const std::string& fingerprint,
                                const std::string& data) {
  return WriteOne(
      "INSERT OR REPLACE INTO keyframe_products(keyframe_id, fingerprint, data, stored_ns)"
      " VALUES(?, ?, ?, ?)",
      [&](Stmt& s) {
        s.Bind(1, keyframe_id).BindText(2, fingerprint).BindBlob(3, data).Bind(4, NowNs());
      },
      "store keyframe products");
}

Status SqliteStore::PutKeyframePoses(const std::vector<KeyframePoseRecord>& poses) {
  return Write([&](sqlite3* db) -> Status {
    Stmt s(db,
           "INSERT OR REPLACE INTO keyframe_poses(keyframe_id, tx, ty, tz, qw, qx, qy, qz,"
           " updated_ns) VALUES(?, ?, ?, ?, ?, ?, ?, ?, ?)");
    if (!s.status().ok()) return SqlError(db, "prepare store keyframe poses");
    const int64_t now_ns = NowNs();
    for (const KeyframePoseRecord& p : poses) {
      s.Reset();
      s.Bind(1, p.keyframe_id);
      BindPose(s, 2, p.T_base_kf);
      s.Bind(9, now_ns);
      if (s.Step() != SQLITE_DONE) {
        return SqlError(db, absl::StrCat("store the pose of keyframe ", p.keyframe_id));
      }
    }
    return absl::OkStatus();
  });
}

Status SqliteStore::PutPlaceMatch(const PlaceMatchRecord& m) {
  return Write([&](sqlite3* db) -> Status {
    Stmt s(db,
           "INSERT OR REPLACE INTO place_matches(a_keyframe_id, b_keyframe_id, tx, ty, tz, qw, qx,"
           " qy, qz, inliers, rms_m, found_ns) VALUES(?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
    if (!s.status().ok()) return SqlError(db, "prepare store place match");
    s.Bind(1, m.a_keyframe_id).Bind(2, m.b_keyframe_id);
    BindPose(s, 3, m.T_a_b);
    s.Bind(10, static_cast<int64_t>(m.inliers)).Bind(11, m.rms_m).Bind(12, NowNs());
    if (s.Step() != SQLITE_DONE) {
      return SqlError(db, absl::StrCat("store the match of keyframes ", m.a_keyframe_id, " and ",
                                       m.b_keyframe_id));
    }
    return absl::OkStatus();
  });
}

StatusOr<std::vector<PlaceMatchRecord>> SqliteStore::ListPlaceMatches() {
  LOCI_ASSIGN_OR_RETURN(auto reader, readers_.Acquire());
  Stmt q(reader.get(),
         "SELECT a_keyframe_id, b_keyframe_id, tx, ty, tz, qw, qx, qy, qz, inliers, rms_m"
         " FROM place_matches ORDER BY b_keyframe_id, a_keyframe_id");
  LOCI_RETURN_IF_ERROR(q.status());
  std::vector<PlaceMatchRecord> out;
  int rc;
  while ((rc = q.Step()) == SQLITE_ROW) {
    out.push_back({q.Int(0), q.Int(1), PoseFrom(q, 2), static_cast<int>(q.Int(9)), q.Real(10)});
  }
  if (rc != SQLITE_DONE) return SqlError(reader.get(), "read place matches");
  return out;
}

StatusOr<std::optional<std::string>> SqliteStore::ReadKeyed(const char* sql,
                                                            int64_t keyframe_id,
                                                            const std::string& fingerprint,
                                                            const char* what) {
  LOCI_ASSIGN_OR_RETURN(auto reader, readers_.Acquire());
  Stmt q(reader.get(), sql);
  LOCI_RETURN_IF_ERROR(q.status());
  q.Bind(1, keyframe_id).BindText(2, fingerprint);
  const int rc = q.Step();
  if (rc == SQLITE_DONE) return std::optional<std::string>();
  if (rc != SQLITE_ROW) return SqlError(reader.get(), what);
  return std::optional<std::string>(q.Text(0));
}

StatusOr<std::optional<std::string>> SqliteStore::GetProducts(int64_t keyframe_id,
                                                              const std::string& fingerprint) {
  return ReadKeyed("SELECT data FROM keyframe_products WHERE keyframe_id = ? AND fingerprint = ?",
                   keyframe_id, fingerprint, "read products");
}

Status SqliteStore::PutPlaceFeatures(int64_t keyframe_id, const std::string& fingerprint,
                                     const std::string& data) {
  return WriteOne(
      "INSERT OR REPLACE INTO place_features(keyframe_id, fingerprint, data) VALUES(?, ?, ?)",
      [&](Stmt& s) { s.Bind(1, keyframe_id).BindText(2, fingerprint).BindBlob(3, data); },
      "store place features");
}

StatusOr<std::optional<std::string>> SqliteStore::GetPlaceFeatures(
    int64_t keyframe_id, const std::string& fingerprint) {
  return ReadKeyed("SELECT data FROM place_features WHERE keyframe_id = ? AND fingerprint = ?",
                   keyframe_id, fingerprint, "read place features");
}

Status SqliteStore::DeleteAllProducts() {
  return WriteOne("DELETE FROM keyframe_products", [](Stmt&) {}, "delete products");
}

Status SqliteStore::PutCheckpoint(const CheckpointRecord& checkpoint) {
  std::lock_guard<std::mutex> lock(write_mu_);
  LOCI_ASSIGN_OR_RETURN(sqlite3 * db, Writer());
  Transaction tx(db);
  LOCI_RETURN_IF_ERROR(tx.status());
  {
    Stmt ins(db, "INSERT INTO checkpoints(last_keyframe_id, data, stored_ns) VALUES(?, ?, ?)");
    if (!ins.status().ok()) return SqlError(db, "prepare checkpoint");
    ins.Bind(1, checkpoint.last_keyframe_id).BindBlob(2, checkpoint.data).Bind(3, NowNs());
    if (ins.Step() != SQLITE_DONE) return SqlError(db, "store checkpoint");
  }
  const int64_t id = sqlite3_last_insert_rowid(db);
  {
    Stmt del(db, "DELETE FROM checkpoints WHERE id < ?");
    del.Bind(1, id);
    if (del.Step() != SQLITE_DONE) return SqlError(db, "drop old checkpoints");
  }
  return tx.Commit();
}

StatusOr<std::optional<CheckpointRecord>> SqliteStore::LatestCheckpoint() {
  LOCI_ASSIGN_OR_RETURN(auto reader, readers_.Acquire());
  Stmt q(reader.get(), "SELECT last_keyframe_id, data FROM checkpoints ORDER BY id DESC LIMIT 1");
  LOCI_RETURN_IF_ERROR(q.status());
  const int rc = q.Step();
  if (rc == SQLITE_DONE) return std::optional<CheckpointRecord>();
  if (rc != SQLITE_ROW) return SqlError(reader.get(), "read checkpoint");
  return std::optional<CheckpointRecord>(CheckpointRecord{q.Int(0), q.Text(1)});
}

Status SqliteStore::DeleteCheckpoints() {
  return WriteOne("DELETE FROM checkpoints", [](Stmt&) {}, "delete checkpoints");
}

StatusOr<uint64_t> SqliteStore::DropRawImages(int64_t before_stored_ns, int64_t keep_last) {
  std::lock_guard<std::mutex> lock(write_mu_);
  LOCI_ASSIGN_OR_RETURN(sqlite3 * db, Writer());
  Transaction tx(db);
  LOCI_RETURN_IF_ERROR(tx.status());
  {
    // keep_last < 0: no count limit; the newest keep_last keyframes keep their images.
    Stmt s(db,
           "UPDATE keyframes SET rgb_jpeg = x'', depth_png = x''"
           " WHERE length(rgb_jpeg) > 0"
           " AND id IN (SELECT keyframe_id FROM keyframe_products)"
           " AND (stored_ns < ?1 OR (?2 >= 0 AND id <= (SELECT COALESCE(MAX(id), 0) - ?2"
           " FROM keyframes)))");
    if (!s.status().ok()) return SqlError(db, "prepare retention");
    s.Bind(1, before_stored_ns).Bind(2, keep_last);
    if (s.Step() != SQLITE_DONE) return SqlError(db, "retention");
  }
  const uint64_t n = static_cast<uint64_t>(sqlite3_changes(db));
  LOCI_RETURN_IF_ERROR(tx.Commit());
  return n;
}

StatusOr<StorageBytes> SqliteStore::Bytes() {
  LOCI_ASSIGN_OR_RETURN(auto reader, readers_.Acquire());
  StorageBytes b;
  Stmt k(reader.get(),
         "SELECT COUNT(*), SUM(length(rgb_jpeg) > 0),"
         " COALESCE(SUM(length(rgb_jpeg) + length(depth_png) + length(detections)), 0)"
         " FROM keyframes");
  if (k.Step() != SQLITE_ROW) return SqlError(reader.get(), "keyframe bytes");
  b.keyframes = static_cast<uint64_t>(k.Int(0));
  b.keyframes_with_raw = static_cast<uint64_t>(k.Int(1));
  b.raw_bytes = static_cast<uint64_t>(k.Int(2));
  Stmt p(reader.get(), "SELECT COUNT(*), COALESCE(SUM(length(data)), 0) FROM keyframe_products");
  if (p.Step() != SQLITE_ROW) return SqlError(reader.get(), "product bytes");
  b.products = static_cast<uint64_t>(p.Int(0));
  b.product_bytes = static_cast<uint64_t>(p.Int(1));
  Stmt c(reader.get(), "SELECT COALESCE(MAX(length(data)), 0) FROM checkpoints");
  if (c.Step() != SQLITE_ROW) return SqlError(reader.get(), "checkpoint bytes");
  b.checkpoint_bytes = static_cast<uint64_t>(c.Int(0));
  Stmt f(reader.get(), "SELECT COUNT(*), COALESCE(SUM(length(data)), 0) FROM place_features");
  if (f.Step() != SQLITE_ROW) return SqlError(reader.get(), "place feature bytes");
  b.place_features = static_cast<uint64_t>(f.Int(0));
  b.place_feature_bytes = static_cast<uint64_t>(f.Int(1));
  return b;
}

}  // namespace loci::server
