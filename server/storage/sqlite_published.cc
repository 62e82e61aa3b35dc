// SqliteStore: the published map (schema/009_published_map.sql): the object table, the robots'
// latest poses and the one-row map state, changed by one transaction per publication.
#include <sqlite3.h>

#include "absl/strings/str_cat.h"
#include "common/time.h"
#include "server/storage/sqlite_store.h"
#include "server/storage/sqlite_util.h"

namespace loci::server {

using sqlite::BindPose;
using sqlite::PoseFrom;
using sqlite::SqlError;
using sqlite::Stmt;

namespace {

Status RunOnce(sqlite3* db, const char* sql, const char* what) {
  Stmt s(db, sql);
  if (!s.status().ok() || s.Step() != SQLITE_DONE) return SqlError(db, what);
  return absl::OkStatus();
}

Status UpsertObjects(sqlite3* db, const std::vector<ObjectRecord>& objects) {
  Stmt ins(db,
           "INSERT OR REPLACE INTO objects(id, class_name, confidence, confirmed, cx, cy, cz,"
           " min_x, min_y, min_z, max_x, max_y, max_z, observation_count, last_seen_ns,"
           " removed_t_ns, object_pb) VALUES(?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
  if (!ins.status().ok()) return SqlError(db, "prepare object table");
  for (const ObjectRecord& o : objects) {
    ins.Reset();
    ins.Bind(1, o.id).BindText(2, o.class_name).Bind(3, o.confidence);
    ins.Bind(4, static_cast<int64_t>(o.confirmed));
    for (int i = 0; i < 3; ++i) {
      ins.Bind(5 + i, o.centroid_m[i]).Bind(8 + i, o.min_m[i]).Bind(11 + i, o.max_m[i]);
    }
    ins.Bind(14, static_cast<int64_t>(o.observation_count)).Bind(15, o.last_seen_ns);
    ins.Bind(16, o.removed_t_ns).BindBlob(17, o.wire);
    if (ins.Step() != SQLITE_DONE) return SqlError(db, absl::StrCat("store object ", o.id));
  }
  return absl::OkStatus();
}

Status DeleteObjects(sqlite3* db, const std::vector<int64_t>& ids) {
  Stmt del(db, "DELETE FROM objects WHERE id = ?");
  if (!del.status().ok()) return SqlError(db, "prepare object delete");
  for (int64_t id : ids) {
    del.Reset();
    del.Bind(1, id);
    if (del.Step() != SQLITE_DONE) return SqlError(db, absl::StrCat("delete object ", id));
  }
  return absl::OkStatus();
}

Status ReplacePoses(sqlite3* db, const std::vector<PublishedPose>& poses) {
  LOCI_RETURN_IF_ERROR(RunOnce(db, "DELETE FROM robot_poses", "clear robot poses"));
  Stmt ins(db,
           "INSERT INTO robot_poses(robot, t_ns, tx, ty, tz, qw, qx, qy, qz)"
           " VALUES(?, ?, ?, ?, ?, ?, ?, ?, ?)");
  if (!ins.status().ok()) return SqlError(db, "prepare robot poses");
  for (const PublishedPose& p : poses) {
    ins.Reset();
    ins.BindText(1, p.robot).Bind(2, p.t_ns);
    BindPose(ins, 3, p.T_map_cam);
    if (ins.Step() != SQLITE_DONE) return SqlError(db, "store robot pose of " + p.robot);
  }
  return absl::OkStatus();
}

Status WriteState(sqlite3* db, const MapPublication& p) {
  Stmt s(db,
         "INSERT INTO map_state(id, version, published_ns, last_keyframe_id, up_x, up_y, up_z,"
         " levelled_by) VALUES(1, 1, ?, ?, ?, ?, ?, ?) ON CONFLICT(id) DO UPDATE SET"
         " version = version + 1, published_ns = excluded.published_ns,"
         " last_keyframe_id = excluded.last_keyframe_id, up_x = excluded.up_x,"
         " up_y = excluded.up_y, up_z = excluded.up_z, levelled_by = excluded.levelled_by");
  if (!s.status().ok()) return SqlError(db, "prepare map state");
  s.Bind(1, NowNs()).Bind(2, p.last_keyframe_id);
  if (p.up_map) {
    for (int i = 0; i < 3; ++i) s.Bind(3 + i, (*p.up_map)[i]);
  }  // unbound parameters are NULL
  s.BindText(6, p.levelled_by);
  if (s.Step() != SQLITE_DONE) return SqlError(db, "store map state");
  return absl::OkStatus();
}

StatusOr<std::vector<ObjectRecord>> ReadObjects(sqlite3* db) {
  Stmt q(db,
         "SELECT id, class_name, confidence, confirmed, cx, cy, cz, min_x, min_y, min_z, max_x,"
         " max_y, max_z, observation_count, last_seen_ns, removed_t_ns, object_pb FROM objects"
         " ORDER BY id");
  LOCI_RETURN_IF_ERROR(q.status());
  std::vector<ObjectRecord> out;
  int rc;
  while ((rc = q.Step()) == SQLITE_ROW) {
    ObjectRecord o;
    o.id = q.Int(0);
    o.class_name = q.Text(1);
    o.confidence = q.Real(2);
    o.confirmed = q.Int(3) != 0;
    o.centroid_m = Vec3d(q.Real(4), q.Real(5), q.Real(6));
    o.min_m = Vec3d(q.Real(7), q.Real(8), q.Real(9));
    o.max_m = Vec3d(q.Real(10), q.Real(11), q.Real(12));
    o.observation_count = static_cast<uint32_t>(q.Int(13));
    o.last_seen_ns = q.Int(14);
    o.removed_t_ns = q.Int(15);
    o.wire = q.Text(16);
    out.push_back(std::move(o));
  }
  if (rc != SQLITE_DONE) return SqlError(db, "read the object table");
  return out;
}

StatusOr<PublishedMap> ReadPublishedTables(sqlite3* db) {
  PublishedMap out;
  {
    Stmt q(db,
           "SELECT version, published_ns, last_keyframe_id, up_x, up_y, up_z, levelled_by"
           " FROM map_state WHERE id = 1");
    LOCI_RETURN_IF_ERROR(q.status());
    if (q.Step() == SQLITE_ROW) {
      out.version = q.Int(0);
      out.published_ns = q.Int(1);
      out.last_keyframe_id = q.Int(2);
      if (!q.IsNull(3)) out.up_map = Vec3d(q.Real(3), q.Real(4), q.Real(5));
      out.levelled_by = q.Text(6);
    }
  }
  LOCI_ASSIGN_OR_RETURN(out.objects, ReadObjects(db));
  Stmt q(db, "SELECT robot, t_ns, tx, ty, tz, qw, qx, qy, qz FROM robot_poses ORDER BY robot");
  LOCI_RETURN_IF_ERROR(q.status());
  int rc;
  while ((rc = q.Step()) == SQLITE_ROW) out.poses.push_back({q.Text(0), q.Int(1), PoseFrom(q, 2)});
  if (rc != SQLITE_DONE) return SqlError(db, "read robot poses");
  return out;
}

}  // namespace

Status SqliteStore::Publish(const MapPublication& publication) {
  return Write([&](sqlite3* db) -> Status {
    if (publication.replace_all) {
      LOCI_RETURN_IF_ERROR(RunOnce(db, "DELETE FROM objects", "clear the object table"));
    }
    LOCI_RETURN_IF_ERROR(DeleteObjects(db, publication.gone_ids));
    LOCI_RETURN_IF_ERROR(UpsertObjects(db, publication.objects));
    LOCI_RETURN_IF_ERROR(ReplacePoses(db, publication.poses));
    return WriteState(db, publication);
  });
}

StatusOr<PublishedMap> SqliteStore::ReadPublished() {
  LOCI_ASSIGN_OR_RETURN(auto reader, readers_.Acquire());
  sqlite3* db = reader.get();
  // One read transaction: the three tables from the same publication.
  LOCI_RETURN_IF_ERROR(RunOnce(db, "BEGIN", "begin reading the published map"));
  StatusOr<PublishedMap> out = ReadPublishedTables(db);
  sqlite3_exec(db, "COMMIT", nullptr, nullptr, nullptr);
  return out;
}

StatusOr<int64_t> SqliteStore::PublishedVersion() {
  LOCI_ASSIGN_OR_RETURN(auto reader, readers_.Acquire());
  Stmt q(reader.get(), "SELECT version FROM map_state WHERE id = 1");
  LOCI_RETURN_IF_ERROR(q.status());
  const int rc = q.Step();
  if (rc == SQLITE_ROW) return q.Int(0);
  if (rc != SQLITE_DONE) return SqlError(reader.get(), "read the published version");
  return int64_t{0};
}

}  // namespace loci::server
