#include <gtest/gtest.h>

#include <regex>
#include <sqlite3.h>

#include <filesystem>
#include <thread>

#include "common/image_codec.h"
#include "server/storage/sqlite_store.h"
#include "server/storage/sqlite_util.h"

namespace loci::server {
namespace {

std::string FreshDb(const std::string& name) {
  const std::string path = ::testing::TempDir() + "/" + name + ".db";
  for (const char* s : {"", "-wal", "-shm"}) std::filesystem::remove(path + s);
  return path;
}

KeyframeRecord MakeKeyframe(int64_t session_row, int64_t seq) {
  KeyframeRecord kf;
  kf.session_row = session_row;
  kf.seq = seq;
  kf.t_ns = 1'700'000'000'000'000'000 + seq * 33'000'000;
  kf.T_odom_cam =
      MakeSE3(Vec3d(0.1 * seq, -0.2, 1.5), Quatd(Eigen::AngleAxisd(0.3, Vec3d::UnitY())));
  kf.camera = PinholeCamera::TumFr1();
  kf.depth_scale = 5000;
  kf.has_gravity = true;
  kf.gravity_cam = Vec3d(0, 1, 0);
  kf.segment = 2;
  kf.tracking_inliers = 150 + static_cast<int>(seq);
  kf.rgb_jpeg = std::string("\xff\xd8 jpeg bytes \0 with a zero", 26);
  kf.depth_png = "png bytes";
  Detection2D d;
  d.class_id = 41;
  d.class_name = "cup";
  d.score = 0.8f;
  d.box_px = cv::Rect2f(10, 20, 30, 40);
  d.track_id = 5;
  d.mask = cv::Mat(40, 30, CV_8UC1, cv::Scalar(255));
  kf.detections.push_back(d);
  return kf;
}

TEST(SqliteStore, FreshDatabaseHasLatestSchemaAndWal) {
  const std::string path = FreshDb("schema");
  auto store = SqliteStore::Open(path);
  ASSERT_TRUE(store.ok()) << store.status();
  EXPECT_GE(SqliteStore::LatestSchemaVersion(), 1);
  EXPECT_EQ(*(*store)->SchemaVersion(), SqliteStore::LatestSchemaVersion());
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* st = nullptr;
  sqlite3_prepare_v2(db, "PRAGMA journal_mode", -1, &st, nullptr);
  ASSERT_EQ(sqlite3_step(st), SQLITE_ROW);
  EXPECT_STREQ(reinterpret_cast<const char*>(sqlite3_column_text(st, 0)), "wal");
  sqlite3_finalize(st);
  sqlite3_close(db);
  // The database holds every camera image: owner-only, and so are its WAL and shared memory.
  namespace fs = std::filesystem;
  for (const std::string& f : {path, path + "-wal", path + "-shm"}) {
    if (!fs::exists(f)) continue;
    EXPECT_EQ(fs::status(f).permissions() & (fs::perms::group_all | fs::perms::others_all),
              fs::perms::none)
        << f;
  }
  EXPECT_TRUE(fs::exists(path + "-wal"));
}

TEST(SqliteStore, RefusesNewerSchema) {
  const std::string path = FreshDb("newer");
  { ASSERT_TRUE(SqliteStore::Open(path).ok()); }
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "UPDATE meta SET value = '999' WHERE key = 'schema_version'", nullptr,
                         nullptr, nullptr),
            SQLITE_OK);
  sqlite3_close(db);
  auto store = SqliteStore::Open(path);
  ASSERT_FALSE(store.ok());
  EXPECT_NE(store.status().message().find("newer"), std::string::npos);
}

TEST(SqliteStore, KeyframeRoundTripAndDuplicates) {
  const std::string path = FreshDb("roundtrip");
  auto store = SqliteStore::Open(path);
  ASSERT_TRUE(store.ok()) << store.status();
  SessionRecord s;
  s.robot_name = "robot1";
  s.camera = PinholeCamera::TumFr1();
  s.T_base_odom = MakeSE3(Vec3d(1, 2, 3), Quatd(Eigen::AngleAxisd(0.5, Vec3d::UnitZ())));
  auto created = (*store)->CreateSession(s);
  ASSERT_TRUE(created.ok()) << created.status();
  // robot-row-<128 random bits>: readable, and not guessable from another robot's id.
  EXPECT_TRUE(std::regex_match(created->session_id, std::regex("robot1-1-[0-9a-f]{32}")))
      << created->session_id;
  EXPECT_EQ(*(*store)->LastStoredSeq(created->row_id), -1);

  const KeyframeRecord kf = MakeKeyframe(created->row_id, 7);
  auto first = (*store)->InsertKeyframe(kf);
  ASSERT_TRUE(first.ok()) << first.status();
  EXPECT_FALSE(first->duplicate);
  auto again = (*store)->InsertKeyframe(kf);
  ASSERT_TRUE(again.ok());
  EXPECT_TRUE(again->duplicate);
  EXPECT_EQ(again->keyframe_id, first->keyframe_id);
  EXPECT_EQ(*(*store)->CountKeyframes(std::nullopt), 1u);
  EXPECT_EQ(*(*store)->LastStoredSeq(created->row_id), 7);

  // A second connection (another thread) reads what the first wrote.
  std::vector<KeyframeRecord> read;
  std::thread reader([&] {
    ASSERT_TRUE((*store)
                    ->ForEachKeyframe(0,
                                      [&](KeyframeRecord r) {
                                        read.push_back(std::move(r));
                                        return absl::OkStatus();
                                      })
                    .ok());
  });
  reader.join();
  ASSERT_EQ(read.size(), 1u);
  const KeyframeRecord& r = read[0];
  EXPECT_EQ(r.id, first->keyframe_id);
  EXPECT_EQ(r.seq, 7);
  EXPECT_EQ(r.t_ns, kf.t_ns);
  EXPECT_TRUE(r.T_odom_cam.isApprox(kf.T_odom_cam, 1e-12));
  EXPECT_EQ(r.camera.width_px, 640);
  EXPECT_DOUBLE_EQ(r.camera.fx, 517.3);
  EXPECT_TRUE(r.has_gravity);
  EXPECT_EQ(r.segment, 2);
  EXPECT_EQ(r.tracking_inliers, 157);
  EXPECT_EQ(r.rgb_jpeg, kf.rgb_jpeg);  // binary-safe, embedded zero kept
  EXPECT_EQ(r.depth_png, kf.depth_png);
  ASSERT_EQ(r.detections.size(), 1u);
  EXPECT_EQ(r.detections[0].class_name, "cup");
  EXPECT_EQ(r.detections[0].track_id, 5);
  EXPECT_EQ(r.detections[0].mask.size(), cv::Size(30, 40));

  auto found = (*store)->FindSession(created->session_id);
  ASSERT_TRUE(found.ok() && found->has_value());
  EXPECT_TRUE((*found)->T_base_odom.isApprox(s.T_base_odom, 1e-12));
  EXPECT_FALSE((*(*store)->FindSession("nope")).has_value());
}

// Robot alignment (schema 4): a session created unaligned is stored so, gets its placement
// and the aligned flag in one update, and a scan can be limited to one session's keyframes.
TEST(SqliteStore, SessionAlignmentIsStoredAndScansFilterBySession) {
  auto store = SqliteStore::Open(FreshDb("alignment"));
  ASSERT_TRUE(store.ok()) << store.status();
  SessionRecord s;
  s.robot_name = "robot2";
  s.camera = PinholeCamera::TumFr1();
  s.aligned = false;
  auto b = (*store)->CreateSession(s);
  s.robot_name = "robot1";
  s.aligned = true;
  auto a = (*store)->CreateSession(s);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_FALSE((*(*store)->FindSession(b->session_id))->aligned);
  EXPECT_TRUE((*(*store)->FindSession(a->session_id))->aligned);
  const SE3d T = MakeSE3(Vec3d(0.5, -1, 0.2), Quatd(Eigen::AngleAxisd(1.0, Vec3d::UnitZ())));
  // Unaligned, b joins another unaligned session's island (here a's row; aligned sessions refuse).
  ASSERT_TRUE((*store)->SetSessionIsland(b->row_id, a->row_id, T.inverse()).ok());
  EXPECT_EQ((*store)->SetSessionIsland(a->row_id, b->row_id, T).code(), absl::StatusCode::kNotFound);
  {
    auto joined = (*store)->FindSession(b->session_id);
    ASSERT_TRUE(joined.ok() && joined->has_value());
    EXPECT_FALSE((*joined)->aligned);
    EXPECT_EQ((*joined)->island_row, a->row_id);
    EXPECT_TRUE((*joined)->T_island_odom.isApprox(T.inverse(), 1e-12));
    EXPECT_EQ((*(*store)->FindSession(a->session_id))->island_row, 0);
  }
  ASSERT_TRUE((*store)->SetSessionAlignment(b->row_id, T).ok());
  auto found = (*store)->FindSession(b->session_id);
  ASSERT_TRUE(found.ok() && found->has_value());
  EXPECT_TRUE((*found)->aligned);
  EXPECT_TRUE((*found)->T_base_odom.isApprox(T, 1e-12));
  EXPECT_EQ((*store)->SetSessionAlignment(999, T).code(), absl::StatusCode::kNotFound);

  for (int seq = 0; seq < 3; ++seq) {
    ASSERT_TRUE((*store)->InsertKeyframe(MakeKeyframe(seq == 1 ? b->row_id : a->row_id, seq)).ok());
  }
  KeyframeScan scan;
  scan.images = false;
  scan.session_row = b->row_id;
  std::vector<int64_t> seqs;
  ASSERT_TRUE((*store)
                  ->ForEachKeyframe(0,
                                    [&](KeyframeRecord r) {
                                      EXPECT_EQ(r.session_row, b->row_id);
                                      seqs.push_back(r.seq);
                                      return absl::OkStatus();
                                    },
                                    scan)
                  .ok());
  EXPECT_EQ(seqs, std::vector<int64_t>({1}));
}

// Verified place matches (loop closure) survive a reopen, a pair stored again replaces the
// first, and a match naming an unknown keyframe is refused (foreign key).
TEST(SqliteStore, PlaceMatchesAreStoredReplacedAndReadBackAfterAReopen) {
  const std::string path = FreshDb("place_matches");
  const SE3d T1 = MakeSE3(Vec3d(0.1, 0.2, -0.3), Quatd(Eigen::AngleAxisd(0.2, Vec3d::UnitY())));
  const SE3d T2 = MakeSE3(Vec3d(-1, 0, 0.5), Quatd(Eigen::AngleAxisd(-0.4, Vec3d::UnitZ())));
  std::vector<int64_t> ids;
  {
    auto store = SqliteStore::Open(path);
    ASSERT_TRUE(store.ok()) << store.status();
    SessionRecord s;
    s.robot_name = "r";
    s.camera = PinholeCamera::TumFr1();
    auto session = (*store)->CreateSession(s);
    ASSERT_TRUE(session.ok());
    for (int seq = 0; seq < 3; ++seq) {
      auto r = (*store)->InsertKeyframe(MakeKeyframe(session->row_id, seq));
      ASSERT_TRUE(r.ok());
      ids.push_back(r->keyframe_id);
    }
    ASSERT_TRUE((*store)->PutPlaceMatch({ids[0], ids[2], T1, 40, 0.012}).ok());
    ASSERT_TRUE((*store)->PutPlaceMatch({ids[1], ids[2], T1, 35, 0.02}).ok());
    ASSERT_TRUE((*store)->PutPlaceMatch({ids[0], ids[2], T2, 90, 0.008}).ok());  // replaces
    EXPECT_FALSE((*store)->PutPlaceMatch({ids[0], 12345, T1, 40, 0.01}).ok());
  }
  auto store = SqliteStore::Open(path);
  ASSERT_TRUE(store.ok()) << store.status();
  auto matches = (*store)->ListPlaceMatches();
  ASSERT_TRUE(matches.ok()) << matches.status();
  ASSERT_EQ(matches->size(), 2u);
  EXPECT_EQ((*matches)[0].a_keyframe_id, ids[0]);
  EXPECT_EQ((*matches)[0].b_keyframe_id, ids[2]);
  EXPECT_TRUE((*matches)[0].T_a_b.isApprox(T2, 1e-12));
  EXPECT_EQ((*matches)[0].inliers, 90);
  EXPECT_DOUBLE_EQ((*matches)[0].rms_m, 0.008);
  EXPECT_EQ((*matches)[1].a_keyframe_id, ids[1]);
}

TEST(SqliteStore, ManyReaderThreadsKeepTheConnectionCountBounded) {
  SqliteStoreOptions o;
  o.max_idle_readers = 2;
  auto store = SqliteStore::Open(FreshDb("bounded"), o);
  ASSERT_TRUE(store.ok()) << store.status();
  SessionRecord s;
  s.robot_name = "r";
  s.camera = PinholeCamera::TumFr1();
  auto session = (*store)->CreateSession(s);
  ASSERT_TRUE(session.ok());
  // 16 short-lived threads, each reading and writing: one connection per thread id kept
  // forever would leave 17 open.
  for (int round = 0; round < 4; ++round) {
    std::vector<std::thread> threads;
    for (int t = 0; t < 4; ++t) {
      threads.emplace_back([&, seq = round * 4 + t] {
        EXPECT_TRUE((*store)->InsertKeyframe(MakeKeyframe(session->row_id, seq)).ok());
        EXPECT_TRUE((*store)->CountKeyframes(std::nullopt).ok());
        EXPECT_TRUE((*store)->ListSessions().ok());
      });
    }
    for (std::thread& t : threads) t.join();
  }
  EXPECT_EQ(*(*store)->CountKeyframes(std::nullopt), 16u);
  EXPECT_LE((*store)->open_connections(), 1u + 2u);  // the writer + at most 2 idle readers
}

// A COMMIT can fail (here: a deferred foreign key); the transaction must not stay open.
TEST(SqliteTransaction, FailedCommitRollsBack) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(":memory:", &db), SQLITE_OK);
  ASSERT_TRUE(sqlite::Exec(db,
                           "PRAGMA foreign_keys=ON;"
                           "CREATE TABLE parent(id INTEGER PRIMARY KEY);"
                           "CREATE TABLE child(id INTEGER PRIMARY KEY, parent INTEGER REFERENCES"
                           " parent(id) DEFERRABLE INITIALLY DEFERRED);")
                  .ok());
  {
    sqlite::Transaction tx(db);
    ASSERT_TRUE(tx.status().ok());
    ASSERT_TRUE(sqlite::Exec(db, "INSERT INTO child(id, parent) VALUES(1, 42);").ok());
    const Status commit = tx.Commit();
    EXPECT_FALSE(commit.ok());
    EXPECT_NE(commit.message().find("FOREIGN KEY"), std::string::npos) << commit;
  }
  EXPECT_NE(sqlite3_get_autocommit(db), 0) << "the failed transaction is still open";
  {
    sqlite::Stmt count(db, "SELECT COUNT(*) FROM child");
    ASSERT_EQ(count.Step(), SQLITE_ROW);
    EXPECT_EQ(count.Int(0), 0);
  }
  {
    sqlite::Transaction tx(db);  // the connection takes new transactions
    ASSERT_TRUE(tx.status().ok()) << tx.status();
    ASSERT_TRUE(sqlite::Exec(db, "INSERT INTO parent(id) VALUES(42);").ok());
    ASSERT_TRUE(sqlite::Exec(db, "INSERT INTO child(id, parent) VALUES(1, 42);").ok());
    EXPECT_TRUE(tx.Commit().ok());
  }
  sqlite3_close(db);
}

TEST(SqliteStore, ResumeFindsLatestOpenSessionAndSurvivesReopen) {
  const std::string path = FreshDb("resume");
  int64_t row = 0;
  {
    auto store = SqliteStore::Open(path);
    ASSERT_TRUE(store.ok());
    SessionRecord s;
    s.robot_name = "r";
    s.camera = PinholeCamera::TumFr1();
    auto a = (*store)->CreateSession(s);
    auto b = (*store)->CreateSession(s);
    ASSERT_TRUE(a.ok() && b.ok());
    ASSERT_TRUE((*store)->CloseSession(b->row_id, 5).ok());
    row = a->row_id;
    for (int seq = 0; seq < 3; ++seq)
      ASSERT_TRUE((*store)->InsertKeyframe(MakeKeyframe(row, seq)).ok());
  }
  auto store = SqliteStore::Open(path);
  ASSERT_TRUE(store.ok());
  auto latest = (*store)->LatestOpenSession("r");
  ASSERT_TRUE(latest.ok() && latest->has_value());
  EXPECT_EQ((*latest)->row_id, row);  // b is closed
  EXPECT_EQ(*(*store)->LastStoredSeq(row), 2);
  EXPECT_EQ((*(*store)->ListSessions()).size(), 2u);
  EXPECT_GT((*store)->DbBytes(), 0u);
}

TEST(SqliteStore, ReadOnlyOpenOfMissingFileFails) {
  SqliteStoreOptions o;
  o.read_only = true;
  auto store = SqliteStore::Open(FreshDb("missing"), o);
  ASSERT_FALSE(store.ok());
  EXPECT_EQ(store.status().code(), absl::StatusCode::kNotFound);
}

}  // namespace
}  // namespace loci::server
