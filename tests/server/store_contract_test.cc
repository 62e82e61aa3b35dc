// The MapStore contract, run against every store: SQLite (the embedded default) and PostgreSQL
// (a throwaway server started by the test, tests/support/temp_postgres.h; skipped, saying why,
// where PostgreSQL is not installed). A store keeps every field exactly, refuses what breaks
// the map's references and survives a reopen.
#include <gtest/gtest.h>

#include <filesystem>
#include <regex>
#include <thread>

#include "server/postgres/postgres_store.h"
#include "server/storage/sqlite_store.h"
#include "tests/server/store_records.h"
#include "tests/support/temp_postgres.h"

namespace loci::server {
namespace {

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

class MapStoreContract : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    if (GetParam() == "postgresql") {
      std::string why_not;
      pg_ = SharedPostgres(&why_not);
      if (pg_ == nullptr) GTEST_SKIP() << "no PostgreSQL server for the test: " << why_not;
    }
  }
  // A fresh, empty store named `name`.
  StatusOr<std::unique_ptr<MapStore>> Fresh(const std::string& name) {
    if (pg_ == nullptr) {
      const std::string path = Path(name);
      for (const char* s : {"", "-wal", "-shm"}) std::filesystem::remove(path + s);
    } else {
      LOCI_RETURN_IF_ERROR(pg_->CreateDatabase(name));
    }
    return Reopen(name);
  }
  // The store `name` opened again (a server restart).
  StatusOr<std::unique_ptr<MapStore>> Reopen(const std::string& name) {
    if (pg_ == nullptr) {
      LOCI_ASSIGN_OR_RETURN(auto s, SqliteStore::Open(Path(name)));
      return std::unique_ptr<MapStore>(std::move(s));
    }
    LOCI_ASSIGN_OR_RETURN(auto s, PostgresStore::Open(pg_->Uri(name)));
    return std::unique_ptr<MapStore>(std::move(s));
  }
  static std::string Path(const std::string& name) {
    return ::testing::TempDir() + "/contract_" + name + ".db";
  }
  static std::vector<KeyframeRecord> Scan(MapStore& store, const KeyframeScan& scan = {},
                                          int64_t after_id = 0) {
    std::vector<KeyframeRecord> out;
    const Status s = store.ForEachKeyframe(
        after_id,
        [&](KeyframeRecord r) {
          out.push_back(std::move(r));
          return absl::OkStatus();
        },
        scan);
    EXPECT_TRUE(s.ok()) << s;
    return out;
  }

  loci::testing::TempPostgres* pg_ = nullptr;
};

TEST_P(MapStoreContract, FreshStoreHasTheLatestSchema) {
  auto store = Fresh("schema");
  ASSERT_TRUE(store.ok()) << store.status();
  auto version = (*store)->SchemaVersion();
  ASSERT_TRUE(version.ok()) << version.status();
  EXPECT_EQ(*version, GetParam() == "sqlite" ? SqliteStore::LatestSchemaVersion()
                                             : PostgresStore::LatestSchemaVersion());
  EXPECT_EQ(*(*store)->CountKeyframes(std::nullopt), 0u);
  EXPECT_FALSE((*(*store)->LatestCheckpoint()).has_value());
}

TEST_P(MapStoreContract, KeyframeRoundTripAndDuplicates) {
  auto store = Fresh("roundtrip");
  ASSERT_TRUE(store.ok()) << store.status();
  SessionRecord s = MakeSession("robot1");
  s.T_base_odom = MakeSE3(Vec3d(1, 2, 3), Quatd(Eigen::AngleAxisd(0.5, Vec3d::UnitZ())));
  auto created = (*store)->CreateSession(s);
  ASSERT_TRUE(created.ok()) << created.status();
  // robot-row-<128 random bits>: readable, and not guessable from another robot's id.
  EXPECT_TRUE(std::regex_match(created->session_id, std::regex("robot1-1-[0-9a-f]{32}")))
      << created->session_id;
  EXPECT_EQ(*(*store)->LastStoredSeq(created->row_id), -1);
  EXPECT_EQ((*(*store)->LastStoredStamp(created->row_id)).seq, -1);

  const KeyframeRecord kf = MakeKeyframe(created->row_id, 7);
  auto first = (*store)->InsertKeyframe(kf);
  ASSERT_TRUE(first.ok()) << first.status();
  EXPECT_FALSE(first->duplicate);
  auto again = (*store)->InsertKeyframe(kf);
  ASSERT_TRUE(again.ok()) << again.status();
  EXPECT_TRUE(again->duplicate);
  EXPECT_FALSE(again->conflict);
  EXPECT_EQ(again->keyframe_id, first->keyframe_id);
  KeyframeRecord other = kf;
  other.rgb_jpeg = "other bytes";
  auto conflicting = (*store)->InsertKeyframe(other);
  ASSERT_TRUE(conflicting.ok()) << conflicting.status();
  EXPECT_TRUE(conflicting->duplicate);
  EXPECT_TRUE(conflicting->conflict);  // the first write wins
  EXPECT_EQ(*(*store)->CountKeyframes(std::nullopt), 1u);
  EXPECT_EQ(*(*store)->CountKeyframes(created->row_id), 1u);
  EXPECT_EQ(*(*store)->LastStoredSeq(created->row_id), 7);
  EXPECT_EQ((*(*store)->LastStoredStamp(created->row_id)).t_ns, kf.t_ns);

  // A second connection (another thread) reads what the first wrote.
  std::vector<KeyframeRecord> read;
  std::thread reader([&] { read = Scan(**store); });
  reader.join();
  ASSERT_EQ(read.size(), 1u);
  const KeyframeRecord& r = read[0];
  EXPECT_EQ(r.id, first->keyframe_id);
  EXPECT_EQ(r.seq, 7);
  EXPECT_EQ(r.t_ns, kf.t_ns);
  EXPECT_TRUE(r.T_odom_cam.isApprox(kf.T_odom_cam, 1e-12));
  EXPECT_EQ(r.camera.width_px, 640);
  EXPECT_DOUBLE_EQ(r.camera.fx, 517.3);
  EXPECT_DOUBLE_EQ(r.depth_scale, 5000);
  EXPECT_TRUE(r.has_gravity);
  EXPECT_TRUE(r.gravity_cam.isApprox(kf.gravity_cam));
  EXPECT_EQ(r.segment, 2);
  EXPECT_EQ(r.tracking_inliers, 157);
  EXPECT_EQ(r.rgb_jpeg, kf.rgb_jpeg);  // binary-safe, embedded zero kept
  EXPECT_EQ(r.depth_png, kf.depth_png);
  ASSERT_EQ(r.detections.size(), 1u);
  EXPECT_EQ(r.detections[0].class_name, "cup");
  EXPECT_EQ(r.detections[0].track_id, 5);
  EXPECT_EQ(r.detections[0].mask.size(), cv::Size(30, 40));
  EXPECT_FALSE(r.T_base_kf_corrected.has_value());

  auto found = (*store)->FindSession(created->session_id);
  ASSERT_TRUE(found.ok() && found->has_value());
  EXPECT_TRUE((*found)->T_base_odom.isApprox(s.T_base_odom, 1e-12));
  EXPECT_FALSE((*(*store)->FindSession("nope")).has_value());
  EXPECT_FALSE((*store)->InsertKeyframe(MakeKeyframe(999, 1)).ok());  // no such session
}

// Robot alignment: a session created unaligned is stored so, joins another session's island,
// gets its placement and the aligned flag in one update; a scan can take one session.
TEST_P(MapStoreContract, SessionAlignmentIsStoredAndScansFilterBySession) {
  auto store = Fresh("alignment");
  ASSERT_TRUE(store.ok()) << store.status();
  auto b = (*store)->CreateSession(MakeSession("robot2", false));
  auto a = (*store)->CreateSession(MakeSession("robot1", true));
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_FALSE((*(*store)->FindSession(b->session_id))->aligned);
  EXPECT_TRUE((*(*store)->FindSession(a->session_id))->aligned);
  const SE3d T = MakeSE3(Vec3d(0.5, -1, 0.2), Quatd(Eigen::AngleAxisd(1.0, Vec3d::UnitZ())));
  ASSERT_TRUE((*store)->SetSessionIsland(b->row_id, a->row_id, T.inverse()).ok());
  EXPECT_EQ((*store)->SetSessionIsland(a->row_id, b->row_id, T).code(),
            absl::StatusCode::kNotFound);  // aligned sessions refuse
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
  const auto only_b = Scan(**store, scan);
  ASSERT_EQ(only_b.size(), 1u);
  EXPECT_EQ(only_b[0].seq, 1);
  EXPECT_TRUE(only_b[0].rgb_jpeg.empty());  // images not read
  EXPECT_TRUE(only_b[0].detections.empty());
}

// Products and place features: replaced when stored again, read only with their fingerprint; a
// products scan reads images only of keyframes without products; corrected poses replace the
// odometry placement; retention empties images of keyframes with products only.
TEST_P(MapStoreContract, ProductsPosesAndRetention) {
  auto store = Fresh("products");
  ASSERT_TRUE(store.ok()) << store.status();
  auto session = (*store)->CreateSession(MakeSession("r"));
  ASSERT_TRUE(session.ok());
  std::vector<int64_t> ids;
  for (int seq = 0; seq < 5; ++seq) {
    auto r = (*store)->InsertKeyframe(MakeKeyframe(session->row_id, seq));
    ASSERT_TRUE(r.ok()) << r.status();
    ids.push_back(r->keyframe_id);
  }
  ASSERT_TRUE((*store)->PutProducts(ids[0], "fp1", std::string("p\0a", 3)).ok());
  ASSERT_TRUE((*store)->PutProducts(ids[0], "fp1", "p0").ok());  // replaces
  ASSERT_TRUE((*store)->PutProducts(ids[1], "fp1", "p1").ok());
  ASSERT_TRUE((*store)->PutProducts(ids[2], "old", "p2").ok());
  EXPECT_EQ(**(*store)->GetProducts(ids[0], "fp1"), "p0");
  EXPECT_FALSE((*(*store)->GetProducts(ids[2], "fp1")).has_value());
  EXPECT_FALSE((*store)->PutProducts(12345, "fp1", "x").ok());  // no such keyframe
  ASSERT_TRUE((*store)->PutPlaceFeatures(ids[3], "f1", std::string("LPF1\0", 5)).ok());
  EXPECT_EQ(**(*store)->GetPlaceFeatures(ids[3], "f1"), std::string("LPF1\0", 5));
  EXPECT_FALSE((*(*store)->GetPlaceFeatures(ids[3], "f2")).has_value());

  const SE3d T = MakeSE3(Vec3d(3, 2, 1), Quatd(Eigen::AngleAxisd(0.7, Vec3d::UnitX())));
  ASSERT_TRUE((*store)->PutKeyframePoses({{ids[1], SE3d::Identity()}, {ids[1], T}}).ok());
  KeyframeScan scan;
  scan.products_fingerprint = "fp1";
  const auto rows = Scan(**store, scan);
  ASSERT_EQ(rows.size(), 5u);
  EXPECT_EQ(rows[0].products, "p0");
  EXPECT_TRUE(rows[0].rgb_jpeg.empty());  // has products: no images needed
  EXPECT_EQ(rows[2].products, "");
  EXPECT_FALSE(rows[2].rgb_jpeg.empty());
  ASSERT_TRUE(rows[1].T_base_kf_corrected.has_value());
  EXPECT_TRUE(rows[1].T_base_kf_corrected->isApprox(T, 1e-12));
  EXPECT_EQ(BaseFromKeyframe(rows[1], *session).translation(), T.translation());
  KeyframeScan upto;
  upto.last_id = ids[2];
  EXPECT_EQ(Scan(**store, upto, ids[0]).size(), 2u);

  // Retention: keep the newest 3; of the older two, both have products.
  auto dropped = (*store)->DropRawImages(0, 3);
  ASSERT_TRUE(dropped.ok()) << dropped.status();
  EXPECT_EQ(*dropped, 2u);
  auto bytes = (*store)->Bytes();
  ASSERT_TRUE(bytes.ok()) << bytes.status();
  EXPECT_EQ(bytes->keyframes, 5u);
  EXPECT_EQ(bytes->keyframes_with_raw, 3u);
  EXPECT_EQ(bytes->products, 3u);
  EXPECT_EQ(bytes->place_features, 1u);
  EXPECT_EQ(bytes->place_feature_bytes, 5u);
  ASSERT_TRUE((*store)->DeleteAllProducts().ok());
  EXPECT_EQ((*(*store)->Bytes()).products, 0u);
}

TEST_P(MapStoreContract, CheckpointsKeepOnlyTheLatest) {
  auto store = Fresh("checkpoints");
  ASSERT_TRUE(store.ok()) << store.status();
  ASSERT_TRUE((*store)->PutCheckpoint({4, std::string(100, 'a')}).ok());
  ASSERT_TRUE((*store)->PutCheckpoint({9, std::string(10, 'b')}).ok());
  auto latest = (*store)->LatestCheckpoint();
  ASSERT_TRUE(latest.ok() && latest->has_value()) << latest.status();
  EXPECT_EQ((*latest)->last_keyframe_id, 9);
  EXPECT_EQ((*latest)->data, std::string(10, 'b'));
  EXPECT_EQ((*(*store)->Bytes()).checkpoint_bytes, 10u);  // the older one was dropped
  ASSERT_TRUE((*store)->DeleteCheckpoints().ok());
  EXPECT_FALSE((*(*store)->LatestCheckpoint()).has_value());
}

// An object-table row as a publication carries it, in the map frame.
ObjectRecord Cup(int64_t id, double x) {
  return ObjectRecord{.id = id,
                      .class_name = "cup",
                      .confidence = 0.75,
                      .confirmed = true,
                      .centroid_m = Vec3d(x, 2, 0.8),
                      .min_m = Vec3d(x - 0.04, 1.96, 0.75),
                      .max_m = Vec3d(x + 0.04, 2.04, 0.85),
                      .observation_count = 12,
                      .last_seen_ns = 1'700'000'000'000'000'000 + id,
                      .removed_t_ns = id == 3 ? 1'800'000'000'000'000'000 : 0,
                      .wire = std::string("\x08\x01\0wire", 7) + std::to_string(x)};
}

// A whole publication replaces the table; a change publication upserts and deletes rows and
// replaces the poses and the state; each one counts.
TEST_P(MapStoreContract, PublicationsChangeTheObjectTable) {
  auto store = Fresh("published");
  ASSERT_TRUE(store.ok()) << store.status();
  auto empty = (*store)->ReadPublished();
  ASSERT_TRUE(empty.ok()) << empty.status();
  EXPECT_EQ(empty->version, 0);
  EXPECT_TRUE(empty->objects.empty());
  const SE3d T_map_cam =
      MakeSE3(Vec3d(1, 2, 1.2), Quatd(Eigen::AngleAxisd(0.3, Vec3d::UnitZ())));
  MapPublication first;
  first.replace_all = true;
  first.objects = {Cup(1, 0.5), Cup(2, 1.5), Cup(5, 3.0)};
  first.poses = {{"robot1", 77, T_map_cam}};
  first.up_map = Vec3d(0, 0, 1);
  first.levelled_by = "gravity";
  first.last_keyframe_id = 12;
  ASSERT_TRUE((*store)->Publish(first).ok());
  MapPublication second;
  second.objects = {Cup(3, -1.0), Cup(1, 0.6)};
  second.gone_ids = {2};
  second.poses = {{"robot1", 99, T_map_cam}, {"robot2", 98, T_map_cam}};
  second.levelled_by = "gravity";
  second.last_keyframe_id = 14;
  ASSERT_TRUE((*store)->Publish(second).ok());
  auto published = (*store)->ReadPublished();
  ASSERT_TRUE(published.ok()) << published.status();
  EXPECT_EQ(published->version, 2);
  EXPECT_EQ(*(*store)->PublishedVersion(), 2);
  EXPECT_GT(published->published_ns, 0);
  EXPECT_EQ(published->last_keyframe_id, 14);
  EXPECT_FALSE(published->up_map.has_value());  // the second publication had none
  EXPECT_EQ(published->levelled_by, "gravity");
  ASSERT_EQ(published->poses.size(), 2u);
  EXPECT_EQ(published->poses[0].robot, "robot1");
  EXPECT_EQ(published->poses[0].t_ns, 99);
  EXPECT_TRUE(published->poses[0].T_map_cam.matrix().isApprox(T_map_cam.matrix()));
  const std::vector<ObjectRecord>& objects = published->objects;
  ASSERT_EQ(objects.size(), 3u);  // 1 (moved), 3 (new), 5; 2 is gone
  const ObjectRecord& one = objects[0];
  EXPECT_EQ(one.id, 1);
  EXPECT_EQ(one.class_name, "cup");
  EXPECT_DOUBLE_EQ(one.confidence, 0.75);
  EXPECT_TRUE(one.confirmed);
  EXPECT_TRUE(one.centroid_m.isApprox(Vec3d(0.6, 2, 0.8)));
  EXPECT_TRUE(one.min_m.isApprox(Vec3d(0.56, 1.96, 0.75)));
  EXPECT_TRUE(one.max_m.isApprox(Vec3d(0.64, 2.04, 0.85)));
  EXPECT_EQ(one.observation_count, 12u);
  EXPECT_EQ(one.last_seen_ns, Cup(1, 0).last_seen_ns);
  EXPECT_EQ(one.wire, Cup(1, 0.6).wire);  // bytes, with their zero byte
  EXPECT_EQ(objects[1].id, 3);
  EXPECT_EQ(objects[1].removed_t_ns, Cup(3, 0).removed_t_ns);
  EXPECT_EQ(objects[2].id, 5);
  MapPublication whole;
  whole.replace_all = true;
  whole.objects = {Cup(7, 0.0)};
  ASSERT_TRUE((*store)->Publish(whole).ok());
  auto replaced = (*store)->ReadPublished();
  ASSERT_TRUE(replaced.ok());
  ASSERT_EQ(replaced->objects.size(), 1u);
  EXPECT_EQ(replaced->objects[0].id, 7);
  EXPECT_TRUE(replaced->poses.empty());
}

// Verified place matches survive a reopen, a pair stored again replaces the first, and a match
// naming an unknown keyframe is refused.
TEST_P(MapStoreContract, PlaceMatchesAreStoredReplacedAndReadBackAfterAReopen) {
  const SE3d T1 = MakeSE3(Vec3d(0.1, 0.2, -0.3), Quatd(Eigen::AngleAxisd(0.2, Vec3d::UnitY())));
  const SE3d T2 = MakeSE3(Vec3d(-1, 0, 0.5), Quatd(Eigen::AngleAxisd(-0.4, Vec3d::UnitZ())));
  std::vector<int64_t> ids;
  {
    auto store = Fresh("place_matches");
    ASSERT_TRUE(store.ok()) << store.status();
    auto session = (*store)->CreateSession(MakeSession("r"));
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
  auto store = Reopen("place_matches");
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

TEST_P(MapStoreContract, ResumeFindsLatestOpenSessionAndSurvivesReopen) {
  int64_t row = 0;
  {
    auto store = Fresh("resume");
    ASSERT_TRUE(store.ok()) << store.status();
    auto a = (*store)->CreateSession(MakeSession("r"));
    auto b = (*store)->CreateSession(MakeSession("r"));
    ASSERT_TRUE(a.ok() && b.ok());
    ASSERT_TRUE((*store)->CloseSession(b->row_id, 5).ok());
    row = a->row_id;
    for (int seq = 0; seq < 3; ++seq) {
      ASSERT_TRUE((*store)->InsertKeyframe(MakeKeyframe(row, seq)).ok());
    }
  }
  auto store = Reopen("resume");
  ASSERT_TRUE(store.ok()) << store.status();
  auto latest = (*store)->LatestOpenSession("r");
  ASSERT_TRUE(latest.ok() && latest->has_value());
  EXPECT_EQ((*latest)->row_id, row);  // b is closed
  EXPECT_EQ(*(*store)->LastStoredSeq(row), 2);
  const auto sessions = *(*store)->ListSessions();
  ASSERT_EQ(sessions.size(), 2u);
  EXPECT_FALSE(sessions[1].open);
  EXPECT_GT((*store)->DbBytes(), 0u);
}

// A scan longer than one read page sees every keyframe once, in id order, and stops at the
// first error of its callback.
TEST_P(MapStoreContract, LongScansAreCompleteAndStopOnError) {
  auto store = Fresh("long_scan");
  ASSERT_TRUE(store.ok()) << store.status();
  auto session = (*store)->CreateSession(MakeSession("r"));
  ASSERT_TRUE(session.ok());
  for (int seq = 0; seq < 100; ++seq) {
    ASSERT_TRUE((*store)->InsertKeyframe(MakeKeyframe(session->row_id, seq)).ok());
  }
  const auto all = Scan(**store);
  ASSERT_EQ(all.size(), 100u);
  for (size_t i = 1; i < all.size(); ++i) EXPECT_LT(all[i - 1].id, all[i].id);
  int seen = 0;
  const Status stopped = (*store)->ForEachKeyframe(0, [&](KeyframeRecord) {
    return ++seen == 40 ? absl::AbortedError("enough") : absl::OkStatus();
  });
  EXPECT_EQ(stopped.code(), absl::StatusCode::kAborted);
  EXPECT_EQ(seen, 40);
}

INSTANTIATE_TEST_SUITE_P(Stores, MapStoreContract, ::testing::Values("sqlite", "postgresql"),
                         [](const ::testing::TestParamInfo<std::string>& p) { return p.param; });

}  // namespace
}  // namespace loci::server
