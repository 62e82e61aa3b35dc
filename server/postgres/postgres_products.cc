// PostgresStore: the keyframe scan, per-keyframe products and place features, corrected poses,
// place matches, checkpoints, retention and sizes.
#include "absl/strings/str_cat.h"
#include "common/detections_io.h"
#include "common/time.h"
#include "server/postgres/pg_util.h"
#include "server/postgres/postgres_store.h"

namespace loci::server {

using pg::Exec;
using pg::Params;
using pg::Result;

namespace {

// Keyframes read per round trip: the scan pages by id, so no query stays open while `fn` runs
// and a scan of a large map holds a bounded number of images in memory.
constexpr int kScanPage = 32;

std::string ScanSql(const KeyframeScan& scan) {
  const bool products = !scan.products_fingerprint.empty();
  const char* images = !scan.images ? "NULL::bytea, NULL::bytea, NULL::text"
                       : products   ? "CASE WHEN p.data IS NULL THEN k.rgb_jpeg END,"
                                      " CASE WHEN p.data IS NULL THEN k.depth_png END,"
                                      " CASE WHEN p.data IS NULL THEN k.detections END"
                                    : "k.rgb_jpeg, k.depth_png, k.detections";
  return absl::StrCat(
      "SELECT k.id, k.session, k.seq, k.t_ns, k.tx, k.ty, k.tz, k.qw, k.qx, k.qy, k.qz, k.fx,"
      " k.fy, k.cx, k.cy, k.width_px, k.height_px, k.depth_scale, k.has_gravity, k.gx, k.gy,"
      " k.gz, k.segment, ",
      images, ", ", products ? "p.data" : "NULL::bytea",
      ", c.tx, c.ty, c.tz, c.qw, c.qx, c.qy, c.qz, k.tracking_inliers FROM keyframes k",
      " LEFT JOIN keyframe_poses c ON c.keyframe_id = k.id",
      products ? " LEFT JOIN keyframe_products p ON p.keyframe_id = k.id AND p.fingerprint = $2"
               : "",
      " WHERE k.id > $1 AND ($3 < 0 OR k.session = $3) AND ($4 < 0 OR k.id <= $4)",
      " ORDER BY k.id LIMIT ", kScanPage);
}

StatusOr<KeyframeRecord> RecordFrom(const Result& r, int i) {
  KeyframeRecord kf;
  kf.id = r.Int(i, 0);
  kf.session_row = r.Int(i, 1);
  kf.seq = r.Int(i, 2);
  kf.t_ns = r.Int(i, 3);
  kf.T_odom_cam = r.Pose(i, 4);
  kf.camera = r.Camera(i, 11);
  kf.depth_scale = r.Real(i, 17);
  kf.has_gravity = r.Bool(i, 18);
  kf.gravity_cam = Vec3d(r.Real(i, 19), r.Real(i, 20), r.Real(i, 21));
  kf.segment = static_cast<int>(r.Int(i, 22));
  if (!r.IsNull(i, 23)) kf.rgb_jpeg = r.Bytes(i, 23);
  if (!r.IsNull(i, 24)) kf.depth_png = r.Bytes(i, 24);
  if (!r.IsNull(i, 25)) {
    LOCI_ASSIGN_OR_RETURN(FrameDetections dets, DetectionsFromJsonLine(r.Bytes(i, 25)));
    kf.detections = std::move(dets.detections);
  }
  if (!r.IsNull(i, 26)) kf.products = r.Bytes(i, 26);
  if (!r.IsNull(i, 27)) kf.T_base_kf_corrected = r.Pose(i, 27);
  kf.tracking_inliers = static_cast<int>(r.Int(i, 34));
  return kf;
}

}  // namespace

Status PostgresStore::ForEachKeyframe(int64_t after_id,
                                      const std::function<Status(KeyframeRecord)>& fn,
                                      const KeyframeScan& scan) {
  const std::string sql = ScanSql(scan);
  for (int64_t cursor = after_id;;) {
    std::vector<KeyframeRecord> page;
    LOCI_RETURN_IF_ERROR(Read([&](PGconn* c) -> Status {
      LOCI_ASSIGN_OR_RETURN(Result r, Exec(c, sql,
                                           Params()
                                               .Int(cursor)
                                               .Text(scan.products_fingerprint)
                                               .Int(scan.session_row.value_or(-1))
                                               .Int(scan.last_id.value_or(-1)),
                                           "read keyframes"));
      for (int i = 0; i < r.rows(); ++i) {
        LOCI_ASSIGN_OR_RETURN(KeyframeRecord kf, RecordFrom(r, i));
        page.push_back(std::move(kf));
      }
      return absl::OkStatus();
    }));
    if (page.empty()) return absl::OkStatus();
    cursor = page.back().id;
    const bool last_page = page.size() < static_cast<size_t>(kScanPage);
    for (KeyframeRecord& kf : page) LOCI_RETURN_IF_ERROR(fn(std::move(kf)));
    if (last_page) return absl::OkStatus();
  }
}

Status PostgresStore::PutProducts(int64_t keyframe_id, const std::string& fingerprint,
                                  const std::string& data) {
  return Write([&](PGconn* c) {
    return Exec(c,
                "INSERT INTO keyframe_products(keyframe_id, fingerprint, data, stored_ns)"
                " VALUES($1, $2, $3, $4) ON CONFLICT (keyframe_id) DO UPDATE SET"
                " fingerprint = EXCLUDED.fingerprint, data = EXCLUDED.data,"
                " stored_ns = EXCLUDED.stored_ns",
                Params().Int(keyframe_id).Text(fingerprint).Bytes(data).Int(NowNs()),
                "store keyframe products")
        .status();
  });
}

StatusOr<std::optional<std::string>> PostgresStore::ReadKeyed(const std::string& table,
                                                              int64_t keyframe_id,
                                                              const std::string& fingerprint) {
  std::optional<std::string> out;
  LOCI_RETURN_IF_ERROR(Read([&](PGconn* c) -> Status {
    LOCI_ASSIGN_OR_RETURN(
        Result r,
        Exec(c,
             absl::StrCat("SELECT data FROM ", table,
                          " WHERE keyframe_id = $1 AND fingerprint = $2"),
             Params().Int(keyframe_id).Text(fingerprint), "read " + table));
    if (r.rows() > 0) out = r.Bytes(0, 0);
    return absl::OkStatus();
  }));
  return out;
}

StatusOr<std::optional<std::string>> PostgresStore::GetProducts(int64_t keyframe_id,
                                                                const std::string& fingerprint) {
  return ReadKeyed("keyframe_products", keyframe_id, fingerprint);
}

Status PostgresStore::PutPlaceFeatures(int64_t keyframe_id, const std::string& fingerprint,
                                       const std::string& data) {
  return Write([&](PGconn* c) {
    return Exec(c,
                "INSERT INTO place_features(keyframe_id, fingerprint, data) VALUES($1, $2, $3)"
                " ON CONFLICT (keyframe_id) DO UPDATE SET fingerprint = EXCLUDED.fingerprint,"
                " data = EXCLUDED.data",
                Params().Int(keyframe_id).Text(fingerprint).Bytes(data), "store place features")
        .status();
  });
}

StatusOr<std::optional<std::string>> PostgresStore::GetPlaceFeatures(
    int64_t keyframe_id, const std::string& fingerprint) {
  return ReadKeyed("place_features", keyframe_id, fingerprint);
}

Status PostgresStore::DeleteAllProducts() {
  return Write([](PGconn* c) {
    return Exec(c, "DELETE FROM keyframe_products", Params(), "delete products").status();
  });
}

Status PostgresStore::PutKeyframePoses(const std::vector<KeyframePoseRecord>& poses) {
  return Write([&](PGconn* c) -> Status {
    const int64_t now_ns = NowNs();
    for (const KeyframePoseRecord& p : poses) {
      LOCI_RETURN_IF_ERROR(
          Exec(c,
               "INSERT INTO keyframe_poses(keyframe_id, tx, ty, tz, qw, qx, qy, qz, updated_ns,"
               " position_base) VALUES($1, $2, $3, $4, $5, $6, $7, $8, $9,"
               " ST_MakePoint($2, $3, $4)) ON CONFLICT (keyframe_id) DO UPDATE SET"
               " tx = EXCLUDED.tx, ty = EXCLUDED.ty, tz = EXCLUDED.tz, qw = EXCLUDED.qw,"
               " qx = EXCLUDED.qx, qy = EXCLUDED.qy, qz = EXCLUDED.qz,"
               " updated_ns = EXCLUDED.updated_ns, position_base = EXCLUDED.position_base",
               Params().Int(p.keyframe_id).Pose(p.T_base_kf).Int(now_ns),
               absl::StrCat("store the pose of keyframe ", p.keyframe_id))
              .status());
    }
    return absl::OkStatus();
  });
}

Status PostgresStore::PutPlaceMatch(const PlaceMatchRecord& m) {
  return Write([&](PGconn* c) {
    return Exec(c,
                "INSERT INTO place_matches(a_keyframe_id, b_keyframe_id, tx, ty, tz, qw, qx, qy,"
                " qz, inliers, rms_m, found_ns) VALUES($1, $2, $3, $4, $5, $6, $7, $8, $9, $10,"
                " $11, $12) ON CONFLICT (a_keyframe_id, b_keyframe_id) DO UPDATE SET"
                " tx = EXCLUDED.tx, ty = EXCLUDED.ty, tz = EXCLUDED.tz, qw = EXCLUDED.qw,"
                " qx = EXCLUDED.qx, qy = EXCLUDED.qy, qz = EXCLUDED.qz,"
                " inliers = EXCLUDED.inliers, rms_m = EXCLUDED.rms_m,"
                " found_ns = EXCLUDED.found_ns",
                Params()
                    .Int(m.a_keyframe_id)
                    .Int(m.b_keyframe_id)
                    .Pose(m.T_a_b)
                    .Int(m.inliers)
                    .Real(m.rms_m)
                    .Int(NowNs()),
                absl::StrCat("store the match of keyframes ", m.a_keyframe_id, " and ",
                             m.b_keyframe_id))
        .status();
  });
}

StatusOr<std::vector<PlaceMatchRecord>> PostgresStore::ListPlaceMatches() {
  std::vector<PlaceMatchRecord> out;
  LOCI_RETURN_IF_ERROR(Read([&](PGconn* c) -> Status {
    LOCI_ASSIGN_OR_RETURN(
        Result r, Exec(c,
                       "SELECT a_keyframe_id, b_keyframe_id, tx, ty, tz, qw, qx, qy, qz, inliers,"
                       " rms_m FROM place_matches ORDER BY b_keyframe_id, a_keyframe_id",
                       Params(), "read place matches"));
    for (int i = 0; i < r.rows(); ++i) {
      out.push_back({r.Int(i, 0), r.Int(i, 1), r.Pose(i, 2), static_cast<int>(r.Int(i, 9)),
                     r.Real(i, 10)});
    }
    return absl::OkStatus();
  }));
  return out;
}

Status PostgresStore::PutCheckpoint(const CheckpointRecord& checkpoint) {
  return Write([&](PGconn* c) -> Status {
    LOCI_ASSIGN_OR_RETURN(
        Result r, Exec(c,
                       "INSERT INTO checkpoints(last_keyframe_id, data, stored_ns)"
                       " VALUES($1, $2, $3) RETURNING id",
                       Params().Int(checkpoint.last_keyframe_id).Bytes(checkpoint.data).Int(
                           NowNs()),
                       "store checkpoint"));
    LOCI_RETURN_IF_ERROR(Exec(c, "DELETE FROM checkpoints WHERE id < $1",
                              Params().Int(r.Int(0, 0)), "drop old checkpoints")
                             .status());
    return absl::OkStatus();
  });
}

StatusOr<std::optional<CheckpointRecord>> PostgresStore::LatestCheckpoint() {
  std::optional<CheckpointRecord> out;
  LOCI_RETURN_IF_ERROR(Read([&](PGconn* c) -> Status {
    LOCI_ASSIGN_OR_RETURN(
        Result r, Exec(c,
                       "SELECT last_keyframe_id, data FROM checkpoints ORDER BY id DESC LIMIT 1",
                       Params(), "read checkpoint"));
    if (r.rows() > 0) out = CheckpointRecord{r.Int(0, 0), r.Bytes(0, 1)};
    return absl::OkStatus();
  }));
  return out;
}

Status PostgresStore::DeleteCheckpoints() {
  return Write([](PGconn* c) {
    return Exec(c, "DELETE FROM checkpoints", Params(), "delete checkpoints").status();
  });
}

StatusOr<uint64_t> PostgresStore::DropRawImages(int64_t before_stored_ns, int64_t keep_last) {
  uint64_t n = 0;
  LOCI_RETURN_IF_ERROR(Write([&](PGconn* c) -> Status {
    // keep_last < 0: no count limit; the newest keep_last keyframes keep their images (by
    // rank, so gaps in the ids do not matter).
    LOCI_ASSIGN_OR_RETURN(
        Result r,
        Exec(c,
             "UPDATE keyframes SET rgb_jpeg = ''::bytea, depth_png = ''::bytea"
             " WHERE octet_length(rgb_jpeg) > 0"
             " AND id IN (SELECT keyframe_id FROM keyframe_products)"
             " AND (stored_ns < $1 OR ($2 >= 0 AND id <= COALESCE((SELECT id FROM keyframes"
             " ORDER BY id DESC OFFSET $2 LIMIT 1), 0)))",
             Params().Int(before_stored_ns).Int(keep_last), "retention"));
    n = static_cast<uint64_t>(r.affected());
    return absl::OkStatus();
  }));
  return n;
}

StatusOr<StorageBytes> PostgresStore::Bytes() {
  StorageBytes b;
  LOCI_RETURN_IF_ERROR(Read([&](PGconn* c) -> Status {
    LOCI_ASSIGN_OR_RETURN(
        Result k,
        Exec(c,
             "SELECT COUNT(*), COUNT(*) FILTER (WHERE octet_length(rgb_jpeg) > 0),"
             " COALESCE(SUM(octet_length(rgb_jpeg) + octet_length(depth_png)"
             " + octet_length(detections)), 0)::bigint FROM keyframes",
             Params(), "keyframe bytes"));
    b.keyframes = static_cast<uint64_t>(k.Int(0, 0));
    b.keyframes_with_raw = static_cast<uint64_t>(k.Int(0, 1));
    b.raw_bytes = static_cast<uint64_t>(k.Int(0, 2));
    LOCI_ASSIGN_OR_RETURN(
        Result p, Exec(c,
                       "SELECT COUNT(*), COALESCE(SUM(octet_length(data)), 0)::bigint FROM"
                       " keyframe_products",
                       Params(), "product bytes"));
    b.products = static_cast<uint64_t>(p.Int(0, 0));
    b.product_bytes = static_cast<uint64_t>(p.Int(0, 1));
    LOCI_ASSIGN_OR_RETURN(
        Result ck, Exec(c, "SELECT COALESCE(MAX(octet_length(data)), 0)::bigint FROM checkpoints",
                        Params(), "checkpoint bytes"));
    b.checkpoint_bytes = static_cast<uint64_t>(ck.Int(0, 0));
    LOCI_ASSIGN_OR_RETURN(
        Result f, Exec(c,
                       "SELECT COUNT(*), COALESCE(SUM(octet_length(data)), 0)::bigint FROM"
                       " place_features",
                       Params(), "place feature bytes"));
    b.place_features = static_cast<uint64_t>(f.Int(0, 0));
    b.place_feature_bytes = static_cast<uint64_t>(f.Int(0, 1));
    return absl::OkStatus();
  }));
  return b;
}

uint64_t PostgresStore::DbBytes() {
  uint64_t bytes = 0;
  const Status s = Read([&](PGconn* c) -> Status {
    LOCI_ASSIGN_OR_RETURN(
        Result r, Exec(c,
                       "SELECT COALESCE(SUM(pg_total_relation_size(c.oid)), 0)::bigint FROM"
                       " pg_class c JOIN pg_namespace n ON n.oid = c.relnamespace"
                       " WHERE n.nspname = $1 AND c.relkind = 'r'",
                       Params().Text(schema_), "database size"));
    bytes = static_cast<uint64_t>(r.Int(0, 0));
    return absl::OkStatus();
  });
  return s.ok() ? bytes : 0;
}

}  // namespace loci::server
