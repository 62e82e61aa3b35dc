// What only the PostgreSQL store does: several sites in one database, the writer lease of a site
// with its fence, and PostGIS positions that SQL tools can query.
#include <gtest/gtest.h>
#include <libpq-fe.h>

#include <future>

#include "server/postgres/postgres_store.h"
#include "server/postgres/site_lease.h"
#include "tests/server/store_records.h"
#include "tests/support/temp_postgres.h"

namespace loci::server {
namespace {

class PostgresSites : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!loci::testing::TempPostgres::Available()) GTEST_SKIP() << "PostgreSQL 15 not installed";
    auto pg = loci::testing::TempPostgres::Start();
    ASSERT_TRUE(pg.ok()) << pg.status();
    pg_ = std::move(*pg);
    uri_ = pg_->Uri();
  }
  // One SQL answer as text (a tool reading the map).
  std::string Sql(const std::string& sql) {
    PGconn* c = PQconnectdb(uri_.c_str());
    PGresult* r = PQexec(c, sql.c_str());
    std::string out = PQresultStatus(r) == PGRES_TUPLES_OK && PQntuples(r) > 0
                          ? PQgetvalue(r, 0, 0)
                          : std::string("error: ") + PQresultErrorMessage(r);
    PQclear(r);
    PQfinish(c);
    return out;
  }

  std::unique_ptr<loci::testing::TempPostgres> pg_;
  std::string uri_;
};

TEST_F(PostgresSites, SitesAreSeparateMapsInOneDatabase) {
  PostgresStoreOptions a_options, b_options;
  a_options.site = "building-a";
  b_options.site = "building-b";
  auto a = PostgresStore::Open(uri_, a_options);
  auto b = PostgresStore::Open(uri_, b_options);
  ASSERT_TRUE(a.ok()) << a.status();
  ASSERT_TRUE(b.ok()) << b.status();
  auto sa = (*a)->CreateSession(MakeSession("r1"));
  ASSERT_TRUE(sa.ok()) << sa.status();
  for (int seq = 0; seq < 3; ++seq) {
    ASSERT_TRUE((*a)->InsertKeyframe(MakeKeyframe(sa->row_id, seq)).ok());
  }
  EXPECT_EQ(*(*a)->CountKeyframes(std::nullopt), 3u);
  EXPECT_EQ(*(*b)->CountKeyframes(std::nullopt), 0u);
  EXPECT_TRUE((*(*b)->ListSessions()).empty());
  EXPECT_EQ(Sql("SELECT string_agg(site || '=' || schema_name, ',' ORDER BY site) FROM "
                "loci_sites"),
            "building-a=site_building_a,building-b=site_building_b");

  // A read-only open of a site that has no map is an error, not an empty map.
  PostgresStoreOptions missing;
  missing.site = "nowhere";
  missing.read_only = true;
  EXPECT_EQ(PostgresStore::Open(uri_, missing).status().code(), absl::StatusCode::kNotFound);
  PostgresStoreOptions bad;
  bad.site = "Robert'); DROP TABLE loci_sites; --";
  EXPECT_EQ(PostgresStore::Open(uri_, bad).status().code(), absl::StatusCode::kInvalidArgument);
  // A read-only store reads, and refuses to write.
  PostgresStoreOptions ro = a_options;
  ro.read_only = true;
  auto reader = PostgresStore::Open(uri_, ro);
  ASSERT_TRUE(reader.ok()) << reader.status();
  EXPECT_EQ(*(*reader)->CountKeyframes(std::nullopt), 3u);
  EXPECT_EQ((*reader)->CreateSession(MakeSession("r2")).status().code(),
            absl::StatusCode::kFailedPrecondition);
}

TEST_F(PostgresSites, KeyframePositionsAreSpatiallyIndexedPoints) {
  auto store = PostgresStore::Open(uri_);
  ASSERT_TRUE(store.ok()) << store.status();
  auto s = (*store)->CreateSession(MakeSession("r"));
  ASSERT_TRUE(s.ok());
  std::vector<int64_t> ids;
  for (int seq = 0; seq < 10; ++seq) {  // MakeKeyframe puts keyframe seq at x = 0.1 * seq
    auto r = (*store)->InsertKeyframe(MakeKeyframe(s->row_id, seq));
    ASSERT_TRUE(r.ok());
    ids.push_back(r->keyframe_id);
  }
  ASSERT_TRUE((*store)->PutKeyframePoses({{ids[9], MakeSE3(Vec3d(5, 6, 7), Quatd::Identity())}})
                  .ok());
  EXPECT_EQ(Sql("SELECT count(*) FROM site_default.keyframes WHERE ST_3DDWithin(position_odom,"
                " ST_MakePoint(0.3, -0.2, 1.5), 0.15)"),
            "3");  // seq 2, 3, 4
  EXPECT_EQ(Sql("SELECT ST_AsText(position_base) FROM site_default.keyframe_poses"),
            "POINT Z (5 6 7)");
  EXPECT_EQ(Sql("SELECT count(*) FROM pg_indexes WHERE schemaname = 'site_default' AND"
                " tablename IN ('keyframes', 'keyframe_poses') AND indexdef LIKE '%USING gist%'"),
            "2");
}

// The lease: one holder at a time; a second server waits; a takeover bumps the epoch, and the
// old holder's fenced writes fail without writing anything.
TEST_F(PostgresSites, OneWriterPerSiteAndTheOldWriterIsFencedOut) {
  auto first_store = PostgresStore::Open(uri_);
  ASSERT_TRUE(first_store.ok()) << first_store.status();
  SiteLeaseOptions lease_options;
  lease_options.ttl_s = 1.0;
  lease_options.renew_s = 0.2;
  lease_options.address = "10.0.0.1:50051";
  auto first = SiteLease::Acquire(uri_, "default", lease_options,
                                  [](const LeaseHolder&) { return false; });
  ASSERT_TRUE(first.ok()) << first.status();
  (*first_store)->SetFence((*first)->fence());
  auto session = (*first_store)->CreateSession(MakeSession("r"));
  ASSERT_TRUE(session.ok()) << session.status();

  // While the first renews, a second one waits and sees who holds the site.
  std::atomic<bool> lost{false};
  std::promise<void> lost_signal;
  (*first)->StartRenewing([&](const Status&) {
    if (!lost.exchange(true)) lost_signal.set_value();
  });
  int attempts = 0;
  LeaseHolder seen;
  auto second = SiteLease::Acquire(uri_, "default", lease_options, [&](const LeaseHolder& h) {
    seen = h;
    return ++attempts < 8;  // 8 attempts, 1.6 s: longer than the ttl
  });
  EXPECT_EQ(second.status().code(), absl::StatusCode::kCancelled);
  EXPECT_EQ(seen.address, "10.0.0.1:50051");
  EXPECT_EQ(seen.epoch, 1);
  EXPECT_FALSE(lost);

  // The lease lapses as if its holder had hung (expired by hand), and a third server takes it.
  EXPECT_EQ(Sql("UPDATE loci_site_leases SET expires_at = now() - interval '1 s' RETURNING "
                "site"),
            "default");
  auto third = SiteLease::Acquire(uri_, "default", lease_options,
                                  [](const LeaseHolder&) { return true; });
  ASSERT_TRUE(third.ok()) << third.status();
  EXPECT_EQ((*third)->fence().epoch, 2);
  // The renewal's own callback, waited on with a deadline of a few renewal periods.
  lost_signal.get_future().wait_for(std::chrono::seconds(5));
  EXPECT_TRUE(lost) << "the first holder's renewal did not notice the takeover";
  const uint64_t before = *(*first_store)->CountKeyframes(std::nullopt);
  const auto fenced = (*first_store)->InsertKeyframe(MakeKeyframe(session->row_id, 1));
  EXPECT_EQ(fenced.status().code(), absl::StatusCode::kFailedPrecondition) << fenced.status();
  EXPECT_EQ(*(*first_store)->CountKeyframes(std::nullopt), before);
  // The new holder writes.
  auto second_store = PostgresStore::Open(uri_);
  ASSERT_TRUE(second_store.ok());
  (*second_store)->SetFence((*third)->fence());
  EXPECT_TRUE((*second_store)->InsertKeyframe(MakeKeyframe(session->row_id, 1)).ok());
  // Releasing lets the next server in at once.
  third->reset();
  auto fourth = SiteLease::Acquire(uri_, "default", lease_options,
                                   [](const LeaseHolder&) { return false; });
  ASSERT_TRUE(fourth.ok()) << fourth.status();
  EXPECT_EQ((*fourth)->fence().epoch, 3);
}

// The object table's boxes answer spatial questions in SQL: which objects meet a box.
TEST_F(PostgresSites, ObjectBoxesAreSpatiallyIndexed) {
  auto store = PostgresStore::Open(uri_);
  ASSERT_TRUE(store.ok()) << store.status();
  MapPublication publication;
  publication.replace_all = true;
  for (int i = 0; i < 5; ++i) {  // 40 cm boxes every metre along x
    ObjectRecord o;
    o.id = i + 1;
    o.class_name = i % 2 ? "chair" : "table";
    o.centroid_m = Vec3d(i, 0, 0.4);
    o.min_m = Vec3d(i - 0.2, -0.2, 0);
    o.max_m = Vec3d(i + 0.2, 0.2, 0.8);
    publication.objects.push_back(o);
  }
  publication.poses = {{"robot1", 5, SE3d::Identity()}};
  ASSERT_TRUE((*store)->Publish(publication).ok());
  EXPECT_EQ(Sql("SELECT string_agg(id::text, ',' ORDER BY id) FROM site_default.objects WHERE"
                " box &&& ST_3DMakeBox(ST_MakePoint(0.9, -1, 0), ST_MakePoint(3.1, 1, 1))"),
            "2,3,4");
  // Above the boxes: nothing (the index is 3D).
  EXPECT_EQ(Sql("SELECT count(*) FROM site_default.objects WHERE box &&& ST_3DMakeBox("
                "ST_MakePoint(0.9, -1, 1), ST_MakePoint(3.1, 1, 2))"),
            "0");
  EXPECT_EQ(Sql("SELECT count(*) FROM pg_indexes WHERE schemaname = 'site_default' AND"
                " tablename = 'objects' AND indexdef LIKE '%gist_geometry_ops_nd%'"),
            "2");
  // The robots' positions are points, indexed too.
  EXPECT_EQ(Sql("SELECT robot FROM site_default.robot_poses WHERE position &&& ST_3DMakeBox("
                "ST_MakePoint(-0.5, -0.5, -0.5), ST_MakePoint(0.5, 0.5, 0.5))"),
            "robot1");
}

TEST_F(PostgresSites, UnreachableDatabaseIsAClearError) {
  auto store = PostgresStore::Open("postgresql://loci@127.0.0.1:1/loci?connect_timeout=2");
  ASSERT_FALSE(store.ok());
  EXPECT_EQ(store.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_NE(store.status().message().find("cannot connect to PostgreSQL"), std::string::npos)
      << store.status();
}

}  // namespace
}  // namespace loci::server
