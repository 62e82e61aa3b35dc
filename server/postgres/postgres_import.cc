// PostgresStore: importing a map with its ids (`loci migrate`). Rows are written as the store
// itself writes them (the same columns and geometry), so a reader cannot tell an imported map
// from one mapped here.
#include "absl/strings/str_cat.h"
#include "common/detections_io.h"
#include "server/postgres/pg_util.h"
#include "server/postgres/postgres_store.h"

namespace loci::server {

using pg::Exec;
using pg::Params;
using pg::Result;

Status PostgresStore::ImportSession(const SessionRecord& s, std::optional<int64_t> closed_ns) {
  if (s.row_id <= 0 || s.session_id.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("import session '", s.session_id, "': needs its row id and public id"));
  }
  if (s.open == closed_ns.has_value()) {
    return absl::InvalidArgumentError(
        absl::StrCat("import session ", s.session_id,
                     ": a closed session needs its close time, an open one none"));
  }
  // The map columns hold T_island_odom for a session in another's island (SessionFrom).
  const bool in_island = !s.aligned && s.island_row != 0;
  return Write([&](PGconn* c) {
    Params p;
    p.Int(s.row_id)
        .Text(s.session_id)
        .Text(s.robot_name)
        .Text(s.client_version)
        .Camera(s.camera)
        .Real(s.depth_scale)
        .Pose(in_island ? s.T_island_odom : s.T_base_odom)
        .Int(s.opened_ns)
        .Int(closed_ns.value_or(0))
        .Bool(closed_ns.has_value())
        .Bool(s.aligned)
        .Int(s.island_row)
        .Bool(in_island);
    return Exec(c,
                "INSERT INTO sessions(id, session_id, robot_name, client_version, fx, fy, cx, cy,"
                " width_px, height_px, depth_scale, map_tx, map_ty, map_tz, map_qw, map_qx,"
                " map_qy, map_qz, opened_ns, closed_ns, aligned, island_row) VALUES($1, $2, $3,"
                " $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, $14, $15, $16, $17, $18, $19,"
                " CASE WHEN $21 THEN $20 END, $22, CASE WHEN $24 THEN $23 END)",
                p, absl::StrCat("import session ", s.session_id))
        .status();
  });
}

Status PostgresStore::ImportKeyframe(const KeyframeRecord& kf, int64_t stored_ns) {
  if (kf.id <= 0) return absl::InvalidArgumentError("import keyframe: needs its id");
  return Write([&](PGconn* c) { return InsertKeyframeRow(c, kf, true, stored_ns).status(); });
}

Status PostgresStore::FinishImport() {
  return Write([&](PGconn* c) -> Status {
    for (const char* table : {"sessions", "keyframes", "checkpoints"}) {
      // is_called = false: the next id handed out is max + 1 (1 for an empty table).
      const std::string qualified = absl::StrCat(schema_, ".", table);
      LOCI_RETURN_IF_ERROR(Exec(c,
                                absl::StrCat("SELECT setval(pg_get_serial_sequence($1, 'id'),"
                                             " COALESCE(MAX(id), 0) + 1, false) FROM ",
                                             qualified),
                                Params().Text(qualified),
                                absl::StrCat("move the id sequence of ", table))
                               .status());
    }
    return absl::OkStatus();
  });
}

}  // namespace loci::server
