#include <gtest/gtest.h>

#include <regex>
#include <sqlite3.h>

#include <filesystem>
#include <thread>

#include "common/image_codec.h"
#include "server/storage/sqlite_store.h"
#include "server/storage/sqlite_util.h"
#include "tests/server/store_records.h"

namespace loci::server {
namespace {

std::string FreshDb(const std::string& name) {
  const std::string path = ::testing::TempDir() + "/" + name + ".db";
  for (const char* s : {"", "-wal", "-shm"}) std::filesystem::remove(path + s);
  return path;
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

TEST(SqliteStore, ReadOnlyOpenOfMissingFileFails) {
  SqliteStoreOptions o;
  o.read_only = true;
  auto store = SqliteStore::Open(FreshDb("missing"), o);
  ASSERT_FALSE(store.ok());
  EXPECT_EQ(store.status().code(), absl::StatusCode::kNotFound);
}

}  // namespace
}  // namespace loci::server
