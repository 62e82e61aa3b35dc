// `loci migrate` run as a process: a SQLite map made through the MapStore API (two sessions, one
// closed and one in the other's island, keyframes with and without images, products of two
// fingerprints, place features, corrected poses, matches, a checkpoint) copied into a site of a
// throwaway PostgreSQL server (tests/support/temp_postgres.h; skipped, saying why, where
// PostgreSQL is not installed). Every record must arrive unchanged and with its id, later
// inserts must continue after the imported ids, and a site that holds a map is never filled.
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "common/detections_io.h"
#include "server/postgres/pg_util.h"
#include "server/postgres/postgres_store.h"
#include "server/postgres/site_lease.h"
#include "server/storage/sqlite_store.h"
#include "tests/server/store_records.h"
#include "tests/support/temp_postgres.h"

namespace loci::server {
namespace {

namespace fs = std::filesystem;

constexpr int kKeyframes = 40;
constexpr int64_t kClosedNs = 1'700'000'123'000'000'000;
const std::vector<std::string> kProductFingerprints = {"products-a", "products-b"};
const std::string kFeatureFingerprint = "features-1";

struct Result {
  int rc = -1;
  std::string out, err;
};

std::ostream& operator<<(std::ostream& os, const Result& r) {
  return os << "exit " << r.rc << "\n--- stdout\n" << r.out << "--- stderr\n" << r.err;
}

// Runs `loci ARGS` (ARGS is a shell fragment); stdout and stderr apart.
Result Loci(const std::string& args) {
  static int n = 0;
  const fs::path err_path =
      fs::path(::testing::TempDir()) /
      ("loci_migrate_stderr_" + std::to_string(getpid()) + "_" + std::to_string(n++));
  const std::string cmd = std::string(LOCI_BIN) + " " + args + " 2>" + err_path.string();
  Result r;
  FILE* p = popen(cmd.c_str(), "r");
  if (p == nullptr) return r;
  std::array<char, 4096> buf;
  while (size_t k = fread(buf.data(), 1, buf.size(), p)) r.out.append(buf.data(), k);
  const int status = pclose(p);
  r.rc = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream in(err_path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  r.err = ss.str();
  fs::remove(err_path);
  return r;
}

bool Has(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// One PostgreSQL server for the whole test binary; each test gets its own database.
loci::testing::TempPostgres* SharedPostgres(std::string* why_not) {
  static StatusOr<std::unique_ptr<loci::testing::TempPostgres>> server =
      loci::testing::TempPostgres::Available()
          ? loci::testing::TempPostgres::Start()
          : StatusOr<std::unique_ptr<loci::testing::TempPostgres>>(
                absl::UnavailableError("PostgreSQL 15 binaries not installed"));
  if (!server.ok()) {
    *why_not = std::string(server.status().message());
    return nullptr;
  }
  return server->get();
}

std::vector<KeyframeRecord> Scan(MapStore& store) {
  std::vector<KeyframeRecord> out;
  const Status s = store.ForEachKeyframe(0, [&](KeyframeRecord r) {
    out.push_back(std::move(r));
    return absl::OkStatus();
  });
  EXPECT_TRUE(s.ok()) << s;
  return out;
}

// Translations arrive bit for bit; rotations up to rounding, since each store writes a pose as a
// quaternion and reads it back with its own conversion.
bool SamePose(const SE3d& a, const SE3d& b) {
  return a.translation() == b.translation() && a.linear().isApprox(b.linear(), 1e-12);
}

std::string DetectionsJson(const KeyframeRecord& kf) {
  FrameDetections frame;
  frame.t_ns = kf.t_ns;
  frame.detections = kf.detections;
  return DetectionsToJsonLine(frame);
}

// Binary product bytes with an embedded zero, different per keyframe and fingerprint.
std::string Payload(const std::string& kind, int64_t id) {
  return std::string("\x01\x00", 2) + kind + "-" + std::to_string(id) + std::string(100, 'x');
}

// keyframe id -> stored_ns, read straight from each database (the records do not carry it).
std::map<int64_t, int64_t> SqliteStoredNs(const std::string& path) {
  std::map<int64_t, int64_t> out;
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
  sqlite3_stmt* q = nullptr;
  EXPECT_EQ(sqlite3_prepare_v2(db, "SELECT id, stored_ns FROM keyframes", -1, &q, nullptr),
            SQLITE_OK);
  while (sqlite3_step(q) == SQLITE_ROW)
    out[sqlite3_column_int64(q, 0)] = sqlite3_column_int64(q, 1);
  sqlite3_finalize(q);
  sqlite3_close_v2(db);
  return out;
}

class Migrate : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string why_not;
    pg_ = SharedPostgres(&why_not);
    if (pg_ == nullptr) GTEST_SKIP() << "no PostgreSQL server for the test: " << why_not;
    dir_ = fs::path(::testing::TempDir()) /
           ("loci_migrate_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + "_" +
            std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    if (!dir_.empty()) fs::remove_all(dir_);
  }

  // The SQLite map described at the top of the file.
  void MakeSqliteMap(const std::string& path) {
    auto store = SqliteStore::Open(path);
    ASSERT_TRUE(store.ok()) << store.status();
    SqliteStore& db = **store;

    SessionRecord a = MakeSession("robot1", /*aligned=*/false);
    a.client_version = "loci-track 1.2";
    a.depth_scale = 1000;
    a.opened_ns = 1'700'000'000'000'000'000;
    a.T_base_odom = MakeSE3(Vec3d(1, 2, 3), Quatd(Eigen::AngleAxisd(0.4, Vec3d::UnitZ())));
    auto sa = db.CreateSession(a);
    ASSERT_TRUE(sa.ok()) << sa.status();
    SessionRecord b = MakeSession("robot2", /*aligned=*/false);
    b.opened_ns = 1'700'000'050'000'000'000;
    b.camera.fx = 600.25;
    auto sb = db.CreateSession(b);
    ASSERT_TRUE(sb.ok()) << sb.status();
    const SE3d T_island_odom =
        MakeSE3(Vec3d(-4, 0.5, 0.25), Quatd(Eigen::AngleAxisd(-1.1, Vec3d::UnitY())));
    ASSERT_TRUE(db.SetSessionIsland(sb->row_id, sa->row_id, T_island_odom).ok());

    for (int i = 0; i < kKeyframes; ++i) {
      const bool first = i % 2 == 0;  // the sessions' keyframes interleave in id order
      KeyframeRecord kf = MakeKeyframe(first ? sa->row_id : sb->row_id, i / 2);
      kf.has_gravity = i % 3 != 0;
      kf.segment = i / 10;
      kf.rgb_jpeg += std::to_string(i);
      if (i % 4 == 3) kf.detections.clear();
      auto r = db.InsertKeyframe(kf);
      ASSERT_TRUE(r.ok()) << r.status();
      ASSERT_EQ(r->keyframe_id, i + 1);
    }
    ASSERT_TRUE(db.CloseSession(sa->row_id, kClosedNs).ok());
    // Products on keyframes 1..30, of two fingerprints.
    for (int64_t id = 1; id <= 30; ++id) {
      const std::string& fp = kProductFingerprints[id % 3 == 0 ? 1 : 0];
      ASSERT_TRUE(db.PutProducts(id, fp, Payload(fp, id)).ok());
    }
    for (int64_t id = 5; id < 15; ++id) {
      ASSERT_TRUE(db.PutPlaceFeatures(id, kFeatureFingerprint, Payload("features", id)).ok());
    }
    std::vector<KeyframePoseRecord> poses;
    for (int64_t id : {2, 9, 17, 33, 40}) {
      poses.push_back({id, MakeSE3(Vec3d(0.01 * id, 1, -2),
                                   Quatd(Eigen::AngleAxisd(0.1 * id, Vec3d::UnitZ())))});
    }
    ASSERT_TRUE(db.PutKeyframePoses(poses).ok());
    ASSERT_TRUE(
        db.PutPlaceMatch({3, 31, MakeSE3(Vec3d(0.1, 0.2, 0.3), Quatd::Identity()), 80, 0.012})
            .ok());
    ASSERT_TRUE(
        db.PutPlaceMatch({4, 36,
                          MakeSE3(Vec3d(-1, 0, 0.5), Quatd(Eigen::AngleAxisd(0.2, Vec3d::UnitX()))),
                          45, 0.03})
            .ok());
    ASSERT_TRUE(db.PutPlaceMatch({12, 39, SE3d::Identity(), 120, 0.005}).ok());
    ASSERT_TRUE(db.PutCheckpoint({20, std::string("old checkpoint\0", 15)}).ok());
    server::ObjectRecord chair{.id = 4, .class_name = "chair", .confidence = 0.9,
                               .confirmed = true, .centroid_m = Vec3d(1, 2, 0.45),
                               .min_m = Vec3d(0.7, 1.7, 0), .max_m = Vec3d(1.3, 2.3, 0.9),
                               .observation_count = 20, .last_seen_ns = 123,
                               .wire = std::string("chair\0wire", 10)};
    ASSERT_TRUE(db.PutCheckpoint({35, std::string("checkpoint \0 bytes", 18)}).ok());
    server::MapPublication published;
    published.replace_all = true;
    published.objects = {chair};
    published.poses = {{"robot1", 456, SE3d::Identity()}};
    published.up_map = Vec3d(0, 0, 1);
    published.levelled_by = "gravity";
    published.last_keyframe_id = 35;
    ASSERT_TRUE(db.Publish(published).ok());
    // Retention empties the images of the oldest keyframes with products (ids 1..10).
    auto dropped = db.DropRawImages(0, 30);
    ASSERT_TRUE(dropped.ok()) << dropped.status();
    ASSERT_EQ(*dropped, 10u);
  }

  loci::testing::TempPostgres* pg_ = nullptr;
  fs::path dir_;
};

TEST_F(Migrate, CopiesEveryRecordWithItsIds) {
  const std::string path = (dir_ / "map.db").string();
  ASSERT_NO_FATAL_FAILURE(MakeSqliteMap(path));
  ASSERT_TRUE(pg_->CreateDatabase("migrate_copy").ok());
  const std::string uri = pg_->Uri("migrate_copy");

  const Result r = Loci("migrate --from sqlite:" + path + " --to '" + uri + "' --site lab");
  ASSERT_EQ(r.rc, 0) << r;
  EXPECT_TRUE(Has(r.out,
                  "migrated 2 sessions, 40 keyframes (30 with products, 10 with place features, "
                  "5 corrected poses, 3 matches, checkpoint at keyframe 35) from " +
                      path + " to site lab in "))
      << r;
  EXPECT_TRUE(Has(r.err, "40 / 40 keyframes")) << r;

  SqliteStoreOptions read_only;
  read_only.read_only = true;
  auto src = SqliteStore::Open(path, read_only);
  ASSERT_TRUE(src.ok()) << src.status();
  PostgresStoreOptions site;
  site.site = "lab";
  auto dst = PostgresStore::Open(uri, site);
  ASSERT_TRUE(dst.ok()) << dst.status();

  // Sessions.
  auto src_sessions = (*src)->ListSessions();
  auto dst_sessions = (*dst)->ListSessions();
  ASSERT_TRUE(src_sessions.ok() && dst_sessions.ok());
  ASSERT_EQ(src_sessions->size(), 2u);
  ASSERT_EQ(dst_sessions->size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    const SessionRecord& a = (*src_sessions)[i];
    const SessionRecord& b = (*dst_sessions)[i];
    SCOPED_TRACE(a.session_id);
    EXPECT_EQ(b.row_id, a.row_id);
    EXPECT_EQ(b.session_id, a.session_id);
    EXPECT_EQ(b.robot_name, a.robot_name);
    EXPECT_EQ(b.client_version, a.client_version);
    EXPECT_EQ(b.camera.fx, a.camera.fx);
    EXPECT_EQ(b.camera.fy, a.camera.fy);
    EXPECT_EQ(b.camera.cx, a.camera.cx);
    EXPECT_EQ(b.camera.cy, a.camera.cy);
    EXPECT_EQ(b.camera.width_px, a.camera.width_px);
    EXPECT_EQ(b.camera.height_px, a.camera.height_px);
    EXPECT_EQ(b.depth_scale, a.depth_scale);
    EXPECT_TRUE(SamePose(b.T_base_odom, a.T_base_odom));
    EXPECT_EQ(b.aligned, a.aligned);
    EXPECT_EQ(b.island_row, a.island_row);
    EXPECT_TRUE(SamePose(b.T_island_odom, a.T_island_odom));
    EXPECT_EQ(b.opened_ns, a.opened_ns);
    EXPECT_EQ(b.open, a.open);
  }
  // The map as built: the first session closed, the second in its island.
  EXPECT_FALSE((*dst_sessions)[0].open);
  EXPECT_TRUE((*dst_sessions)[1].open);
  EXPECT_EQ((*dst_sessions)[1].island_row, (*dst_sessions)[0].row_id);
  EXPECT_FALSE((*dst_sessions)[1].T_island_odom.isApprox(SE3d::Identity()));
  EXPECT_FALSE((*dst_sessions)[0].T_base_odom.isApprox(SE3d::Identity()));

  // Keyframes, every field, with corrected poses.
  const std::vector<KeyframeRecord> src_kfs = Scan(**src);
  const std::vector<KeyframeRecord> dst_kfs = Scan(**dst);
  ASSERT_EQ(src_kfs.size(), static_cast<size_t>(kKeyframes));
  ASSERT_EQ(dst_kfs.size(), src_kfs.size());
  int emptied = 0, corrected = 0;
  for (size_t i = 0; i < src_kfs.size(); ++i) {
    const KeyframeRecord& a = src_kfs[i];
    const KeyframeRecord& b = dst_kfs[i];
    SCOPED_TRACE("keyframe " + std::to_string(a.id));
    EXPECT_EQ(b.id, a.id);
    EXPECT_EQ(b.session_row, a.session_row);
    EXPECT_EQ(b.seq, a.seq);
    EXPECT_EQ(b.t_ns, a.t_ns);
    EXPECT_TRUE(SamePose(b.T_odom_cam, a.T_odom_cam));
    EXPECT_EQ(b.camera.fx, a.camera.fx);
    EXPECT_EQ(b.camera.fy, a.camera.fy);
    EXPECT_EQ(b.camera.cx, a.camera.cx);
    EXPECT_EQ(b.camera.cy, a.camera.cy);
    EXPECT_EQ(b.camera.width_px, a.camera.width_px);
    EXPECT_EQ(b.camera.height_px, a.camera.height_px);
    EXPECT_EQ(b.depth_scale, a.depth_scale);
    EXPECT_EQ(b.has_gravity, a.has_gravity);
    EXPECT_EQ(b.gravity_cam, a.gravity_cam);
    EXPECT_EQ(b.segment, a.segment);
    EXPECT_EQ(b.tracking_inliers, a.tracking_inliers);
    EXPECT_EQ(b.rgb_jpeg, a.rgb_jpeg);
    EXPECT_EQ(b.depth_png, a.depth_png);
    ASSERT_EQ(b.detections.size(), a.detections.size());
    EXPECT_EQ(DetectionsJson(b), DetectionsJson(a));
    for (size_t d = 0; d < a.detections.size(); ++d) {
      EXPECT_EQ(b.detections[d].class_name, a.detections[d].class_name);
      EXPECT_EQ(b.detections[d].track_id, a.detections[d].track_id);
      EXPECT_EQ(b.detections[d].mask.size(), a.detections[d].mask.size());
    }
    ASSERT_EQ(b.T_base_kf_corrected.has_value(), a.T_base_kf_corrected.has_value());
    if (a.T_base_kf_corrected) {
      EXPECT_TRUE(SamePose(*b.T_base_kf_corrected, *a.T_base_kf_corrected));
      ++corrected;
    }
    if (a.rgb_jpeg.empty()) ++emptied;
    // Products and features, per fingerprint.
    for (const std::string& fp : kProductFingerprints) {
      auto pa = (*src)->GetProducts(a.id, fp);
      auto pb = (*dst)->GetProducts(a.id, fp);
      ASSERT_TRUE(pa.ok() && pb.ok());
      EXPECT_EQ(*pb, *pa) << fp;
    }
    auto fa = (*src)->GetPlaceFeatures(a.id, kFeatureFingerprint);
    auto fb = (*dst)->GetPlaceFeatures(a.id, kFeatureFingerprint);
    ASSERT_TRUE(fa.ok() && fb.ok());
    EXPECT_EQ(*fb, *fa);
  }
  EXPECT_EQ(emptied, 10);  // images retention had emptied arrive empty
  EXPECT_EQ(corrected, 5);
  auto bytes = (*dst)->Bytes();
  ASSERT_TRUE(bytes.ok()) << bytes.status();
  EXPECT_EQ(bytes->products, 30u);
  EXPECT_EQ(bytes->place_features, 10u);
  EXPECT_EQ(bytes->keyframes_with_raw, 30u);

  // Store times, and the positions PostGIS indexes, as the store writes them.
  const std::map<int64_t, int64_t> src_stored = SqliteStoredNs(path);
  {
    auto conn = pg::Connect(uri, *PostgresStore::SchemaOfSite("lab"));
    ASSERT_TRUE(conn.ok()) << conn.status();
    auto rows = pg::Exec(*conn,
                         "SELECT id, stored_ns, ST_X(position_odom) = tx AND"
                         " ST_Y(position_odom) = ty AND ST_Z(position_odom) = tz FROM keyframes"
                         " ORDER BY id",
                         pg::Params(), "read keyframes");
    ASSERT_TRUE(rows.ok()) << rows.status();
    ASSERT_EQ(rows->rows(), kKeyframes);
    for (int i = 0; i < rows->rows(); ++i) {
      EXPECT_EQ(rows->Int(i, 1), src_stored.at(rows->Int(i, 0)));
      EXPECT_TRUE(rows->Bool(i, 2)) << "keyframe " << rows->Int(i, 0);
    }
    PQfinish(*conn);
  }

  // Matches and the checkpoint.
  auto ma = (*src)->ListPlaceMatches();
  auto mb = (*dst)->ListPlaceMatches();
  ASSERT_TRUE(ma.ok() && mb.ok());
  ASSERT_EQ(ma->size(), 3u);
  ASSERT_EQ(mb->size(), ma->size());
  for (size_t i = 0; i < ma->size(); ++i) {
    EXPECT_EQ((*mb)[i].a_keyframe_id, (*ma)[i].a_keyframe_id);
    EXPECT_EQ((*mb)[i].b_keyframe_id, (*ma)[i].b_keyframe_id);
    EXPECT_TRUE(SamePose((*mb)[i].T_a_b, (*ma)[i].T_a_b));
    EXPECT_EQ((*mb)[i].inliers, (*ma)[i].inliers);
    EXPECT_EQ((*mb)[i].rms_m, (*ma)[i].rms_m);
  }
  auto ca = (*src)->LatestCheckpoint();
  auto cb = (*dst)->LatestCheckpoint();
  ASSERT_TRUE(ca.ok() && cb.ok());
  ASSERT_TRUE(ca->has_value() && cb->has_value());
  EXPECT_EQ((*cb)->last_keyframe_id, 35);
  EXPECT_EQ((*cb)->last_keyframe_id, (*ca)->last_keyframe_id);
  EXPECT_EQ((*cb)->data, (*ca)->data);
  auto published = (*dst)->ReadPublished();  // the object table as last published
  ASSERT_TRUE(published.ok()) << published.status();
  const std::vector<server::ObjectRecord>& table = published->objects;
  ASSERT_EQ(table.size(), 1u);
  EXPECT_EQ(table[0].id, 4);
  EXPECT_EQ(table[0].class_name, "chair");
  EXPECT_TRUE(table[0].max_m.isApprox(Vec3d(1.3, 2.3, 0.9)));
  EXPECT_EQ(table[0].wire, std::string("chair\0wire", 10));
  ASSERT_EQ(published->poses.size(), 1u);
  EXPECT_EQ(published->poses[0].t_ns, 456);
  EXPECT_EQ(published->levelled_by, "gravity");
  EXPECT_EQ(published->last_keyframe_id, 35);

  // Mapping goes on after the imported ids.
  auto created = (*dst)->CreateSession(MakeSession("robot3"));
  ASSERT_TRUE(created.ok()) << created.status();
  EXPECT_EQ(created->row_id, 3);
  EXPECT_TRUE(std::regex_match(created->session_id, std::regex("robot3-3-[0-9a-f]{32}")))
      << created->session_id;
  auto inserted = (*dst)->InsertKeyframe(MakeKeyframe(created->row_id, 0));
  ASSERT_TRUE(inserted.ok()) << inserted.status();
  EXPECT_FALSE(inserted->duplicate);
  EXPECT_EQ(inserted->keyframe_id, kKeyframes + 1);
  ASSERT_TRUE((*dst)->PutCheckpoint({inserted->keyframe_id, "newer"}).ok());
  EXPECT_EQ((*(*dst)->LatestCheckpoint())->data, "newer");
  // A robot resumes its session by the id it was given before the move.
  auto resumed = (*dst)->FindSession((*src_sessions)[1].session_id);
  ASSERT_TRUE(resumed.ok() && resumed->has_value());
  EXPECT_EQ((**resumed).row_id, (*src_sessions)[1].row_id);

  // A site that holds a map is never filled.
  const Result again = Loci("migrate --from " + path + " --to '" + uri + "' --site lab");
  EXPECT_NE(again.rc, 0) << again;
  EXPECT_TRUE(Has(again.err, "site 'lab'")) << again;
  EXPECT_TRUE(Has(again.err, "already holds a map")) << again;
  EXPECT_EQ(*(*dst)->CountKeyframes(std::nullopt), static_cast<uint64_t>(kKeyframes + 1));
}

TEST_F(Migrate, RefusesATargetThatIsNotPostgres) {
  const std::string path = (dir_ / "map.db").string();
  ASSERT_NO_FATAL_FAILURE(MakeSqliteMap(path));
  const Result r = Loci("migrate --from sqlite:" + path + " --to mysql://localhost/loci");
  EXPECT_EQ(r.rc, 1) << r;
  EXPECT_TRUE(Has(r.err, "postgresql://")) << r;
  const Result missing = Loci("migrate --from sqlite:" + (dir_ / "none.db").string() + " --to '" +
                              pg_->Uri("loci") + "'");
  EXPECT_EQ(missing.rc, 1) << missing;
  EXPECT_TRUE(Has(missing.err, "no SQLite map")) << missing;
}

TEST_F(Migrate, RefusesASiteAServerIsMapping) {
  const std::string path = (dir_ / "map.db").string();
  ASSERT_NO_FATAL_FAILURE(MakeSqliteMap(path));
  ASSERT_TRUE(pg_->CreateDatabase("migrate_busy").ok());
  const std::string uri = pg_->Uri("migrate_busy");
  PostgresStoreOptions site;
  site.site = "busy";
  ASSERT_TRUE(PostgresStore::Open(uri, site).ok());  // creates the site
  SiteLeaseOptions options;
  options.ttl_s = 60;
  options.address = "10.0.0.7:50051";
  auto lease = SiteLease::Acquire(uri, "busy", options, [](const LeaseHolder&) { return false; });
  ASSERT_TRUE(lease.ok()) << lease.status();

  const Result r = Loci("migrate --from " + path + " --to '" + uri + "' --site busy");
  EXPECT_EQ(r.rc, 1) << r;
  EXPECT_TRUE(Has(r.err, "site 'busy' is being mapped by a server")) << r;
  EXPECT_TRUE(Has(r.err, "10.0.0.7:50051")) << r;
  auto store = PostgresStore::Open(uri, site);
  ASSERT_TRUE(store.ok()) << store.status();
  EXPECT_EQ(*(*store)->CountKeyframes(std::nullopt), 0u);
}

}  // namespace
}  // namespace loci::server
