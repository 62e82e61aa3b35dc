// PostgresStore: the published map (schema/site/003_published_map.sql): the object table, the
// robots' latest poses and the one-row map state, changed by one fenced transaction per
// publication that notifies channel loci_map; read-only servers LISTEN on it.
#include <poll.h>

#include <cerrno>
#include <cstring>

#include "absl/strings/str_cat.h"
#include "common/time.h"
#include "server/postgres/pg_util.h"
#include "server/postgres/postgres_store.h"

namespace loci::server {

using pg::Exec;
using pg::Params;
using pg::Result;

namespace {

Status UpsertObject(PGconn* c, const ObjectRecord& o) {
  const Vec3d& p = o.centroid_m;
  return Exec(c,
              "INSERT INTO objects(id, class_name, confidence, confirmed, centroid, box,"
              " observation_count, last_seen_ns, removed_t_ns, object_pb) VALUES($1, $2, $3, $4,"
              " ST_MakePoint($5, $6, $7), ST_3DMakeBox(ST_MakePoint($8, $9, $10),"
              " ST_MakePoint($11, $12, $13))::geometry, $14, $15, $16, $17)"
              " ON CONFLICT (id) DO UPDATE SET class_name = EXCLUDED.class_name,"
              " confidence = EXCLUDED.confidence, confirmed = EXCLUDED.confirmed,"
              " centroid = EXCLUDED.centroid, box = EXCLUDED.box,"
              " observation_count = EXCLUDED.observation_count,"
              " last_seen_ns = EXCLUDED.last_seen_ns, removed_t_ns = EXCLUDED.removed_t_ns,"
              " object_pb = EXCLUDED.object_pb",
              Params()
                  .Int(o.id)
                  .Text(o.class_name)
                  .Real(o.confidence)
                  .Bool(o.confirmed)
                  .Real(p.x())
                  .Real(p.y())
                  .Real(p.z())
                  .Real(o.min_m.x())
                  .Real(o.min_m.y())
                  .Real(o.min_m.z())
                  .Real(o.max_m.x())
                  .Real(o.max_m.y())
                  .Real(o.max_m.z())
                  .Int(o.observation_count)
                  .Int(o.last_seen_ns)
                  .Int(o.removed_t_ns)
                  .Bytes(o.wire),
              absl::StrCat("store object ", o.id))
      .status();
}

Status ReplacePoses(PGconn* c, const std::vector<PublishedPose>& poses) {
  LOCI_RETURN_IF_ERROR(Exec(c, "DELETE FROM robot_poses", Params(), "clear robot poses").status());
  for (const PublishedPose& p : poses) {
    LOCI_RETURN_IF_ERROR(
        Exec(c,
             "INSERT INTO robot_poses(robot, t_ns, tx, ty, tz, qw, qx, qy, qz, position)"
             " VALUES($1, $2, $3, $4, $5, $6, $7, $8, $9, ST_MakePoint($3, $4, $5))",
             Params().Text(p.robot).Int(p.t_ns).Pose(p.T_map_cam),
             "store robot pose of " + p.robot)
            .status());
  }
  return absl::OkStatus();
}

Status WriteState(PGconn* c, const MapPublication& p) {
  const Vec3d up = p.up_map.value_or(Vec3d::Zero());
  return Exec(c,
              "INSERT INTO map_state(id, version, published_ns, last_keyframe_id, up_x, up_y,"
              " up_z, levelled_by) VALUES(1, 1, $1, $2, CASE WHEN $3 THEN $4 END,"
              " CASE WHEN $3 THEN $5 END, CASE WHEN $3 THEN $6 END, $7)"
              " ON CONFLICT (id) DO UPDATE SET version = map_state.version + 1,"
              " published_ns = EXCLUDED.published_ns,"
              " last_keyframe_id = EXCLUDED.last_keyframe_id, up_x = EXCLUDED.up_x,"
              " up_y = EXCLUDED.up_y, up_z = EXCLUDED.up_z, levelled_by = EXCLUDED.levelled_by",
              Params()
                  .Int(NowNs())
                  .Int(p.last_keyframe_id)
                  .Bool(p.up_map.has_value())
                  .Real(up.x())
                  .Real(up.y())
                  .Real(up.z())
                  .Text(p.levelled_by),
              "store map state")
      .status();
}

StatusOr<std::vector<ObjectRecord>> ReadObjects(PGconn* c) {
  LOCI_ASSIGN_OR_RETURN(
      Result r, Exec(c,
                     "SELECT id, class_name, confidence, confirmed, ST_X(centroid),"
                     " ST_Y(centroid), ST_Z(centroid), ST_XMin(box), ST_YMin(box),"
                     " ST_ZMin(box), ST_XMax(box), ST_YMax(box), ST_ZMax(box),"
                     " observation_count, last_seen_ns, removed_t_ns, object_pb FROM objects"
                     " ORDER BY id",
                     Params(), "read the object table"));
  std::vector<ObjectRecord> out;
  out.reserve(r.rows());
  for (int i = 0; i < r.rows(); ++i) {
    ObjectRecord o;
    o.id = r.Int(i, 0);
    o.class_name = r.Bytes(i, 1);
    o.confidence = r.Real(i, 2);
    o.confirmed = r.Bool(i, 3);
    o.centroid_m = Vec3d(r.Real(i, 4), r.Real(i, 5), r.Real(i, 6));
    o.min_m = Vec3d(r.Real(i, 7), r.Real(i, 8), r.Real(i, 9));
    o.max_m = Vec3d(r.Real(i, 10), r.Real(i, 11), r.Real(i, 12));
    o.observation_count = static_cast<uint32_t>(r.Int(i, 13));
    o.last_seen_ns = r.Int(i, 14);
    o.removed_t_ns = r.Int(i, 15);
    o.wire = r.Bytes(i, 16);
    out.push_back(std::move(o));
  }
  return out;
}

Status ReadPublishedTables(PGconn* c, PublishedMap* out) {
  LOCI_ASSIGN_OR_RETURN(
      Result s, Exec(c,
                     "SELECT version, published_ns, last_keyframe_id, up_x, up_y, up_z,"
                     " levelled_by FROM map_state WHERE id = 1",
                     Params(), "read map state"));
  if (s.rows() > 0) {
    out->version = s.Int(0, 0);
    out->published_ns = s.Int(0, 1);
    out->last_keyframe_id = s.Int(0, 2);
    if (!s.IsNull(0, 3)) out->up_map = Vec3d(s.Real(0, 3), s.Real(0, 4), s.Real(0, 5));
    out->levelled_by = s.Bytes(0, 6);
  }
  LOCI_ASSIGN_OR_RETURN(out->objects, ReadObjects(c));
  LOCI_ASSIGN_OR_RETURN(Result r, Exec(c,
                                       "SELECT robot, t_ns, tx, ty, tz, qw, qx, qy, qz FROM"
                                       " robot_poses ORDER BY robot",
                                       Params(), "read robot poses"));
  for (int i = 0; i < r.rows(); ++i) {
    out->poses.push_back({r.Bytes(i, 0), r.Int(i, 1), r.Pose(i, 2)});
  }
  return absl::OkStatus();
}

}  // namespace

Status PostgresStore::Publish(const MapPublication& publication) {
  return Write([&](PGconn* c) -> Status {
    if (publication.replace_all) {
      LOCI_RETURN_IF_ERROR(
          Exec(c, "DELETE FROM objects", Params(), "clear the object table").status());
    }
    for (int64_t id : publication.gone_ids) {
      LOCI_RETURN_IF_ERROR(Exec(c, "DELETE FROM objects WHERE id = $1", Params().Int(id),
                                absl::StrCat("delete object ", id))
                               .status());
    }
    for (const ObjectRecord& o : publication.objects) {
      if (Status s = UpsertObject(c, o); !s.ok()) return s;
    }
    LOCI_RETURN_IF_ERROR(ReplacePoses(c, publication.poses));
    LOCI_RETURN_IF_ERROR(WriteState(c, publication));
    // Delivered to the listeners when this transaction commits, and only then.
    return Exec(c, "SELECT pg_notify('loci_map', $1)", Params().Text(options_.site),
                "notify the publication")
        .status();
  });
}

StatusOr<PublishedMap> PostgresStore::ReadPublished() {
  PublishedMap out;
  LOCI_RETURN_IF_ERROR(Read([&](PGconn* c) -> Status {
    // One snapshot: the three tables from the same publication.
    if (Status begin = pg::ExecScript(c, "BEGIN ISOLATION LEVEL REPEATABLE READ READ ONLY",
                                      "begin reading the published map");
        !begin.ok()) {
      return begin;
    }
    Status s = ReadPublishedTables(c, &out);
    const Status end = pg::ExecScript(c, s.ok() ? "COMMIT" : "ROLLBACK", "end the read");
    return s.ok() ? end : s;
  }));
  return out;
}

StatusOr<int64_t> PostgresStore::PublishedVersion() {
  int64_t version = 0;
  LOCI_RETURN_IF_ERROR(Read([&](PGconn* c) -> Status {
    LOCI_ASSIGN_OR_RETURN(Result r, Exec(c, "SELECT version FROM map_state WHERE id = 1",
                                         Params(), "read the published version"));
    if (r.rows() > 0) version = r.Int(0, 0);
    return absl::OkStatus();
  }));
  return version;
}

StatusOr<int64_t> PostgresStore::WaitPublished(int64_t known, std::chrono::milliseconds timeout) {
  std::lock_guard<std::mutex> lock(listen_mu_);
  if (!pg::Healthy(listener_)) {  // first call, or the database restarted
    if (listener_ != nullptr) PQfinish(listener_);
    listener_ = nullptr;
    LOCI_ASSIGN_OR_RETURN(PGconn * conn, OpenConnection());
    listener_ = conn;
    LOCI_RETURN_IF_ERROR(pg::ExecScript(listener_, "LISTEN loci_map", "listen on loci_map"));
  }
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (true) {
    // Read after LISTEN is in place: a publication committed before it is seen here, one
    // committed after it notifies.
    LOCI_ASSIGN_OR_RETURN(const int64_t version, PublishedVersion());
    if (version > known) return version;
    bool notified = false;
    while (!notified) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0) return version;
      pollfd fd{PQsocket(listener_), POLLIN, 0};
      if (poll(&fd, 1, static_cast<int>(left.count())) < 0 && errno != EINTR) {
        return absl::InternalError(absl::StrCat("poll on the listener: ", std::strerror(errno)));
      }
      if (PQconsumeInput(listener_) == 0) {
        return absl::UnavailableError(absl::StrCat("listening on loci_map: ",
                                                   PQerrorMessage(listener_)));
      }
      while (PGnotify* n = PQnotifies(listener_)) {
        notified = notified || options_.site == n->extra;
        PQfreemem(n);
      }
    }
  }
}

}  // namespace loci::server
