// MapStore on SQLite: WAL journal, one write connection behind a mutex (SQLite runs one writer
// at a time anyway) and a small pool of read connections, schema migrated from the checked-in
// server/storage/schema/NNN_*.sql files on open.
#pragma once

#include <memory>
#include <mutex>
#include <functional>
#include <string>

#include "server/storage/map_store.h"
#include "server/storage/sqlite_pool.h"

namespace loci::server {
namespace sqlite {
class Stmt;
}  // namespace sqlite

struct SqliteStoreOptions {
  // Milliseconds a writer waits for a lock held by another connection before failing (default
  // 5000).
  int busy_timeout_ms = 5000;
  // Open read-only (exports, offline evaluation): no schema migration, no writes (default false).
  bool read_only = false;
  // Read connections kept open between reads (default 4); more readers at once open more, which
  // are closed again after use.
  int max_idle_readers = 4;
};

class SqliteStore final : public MapStore {
 public:
  // Opens (creating when needed) the database and migrates its schema to the latest version.
  static StatusOr<std::unique_ptr<SqliteStore>> Open(const std::string& path,
                                                     SqliteStoreOptions options = {});
  ~SqliteStore() override;
  SqliteStore(const SqliteStore&) = delete;
  SqliteStore& operator=(const SqliteStore&) = delete;

  // Latest schema version this build knows.
  static int LatestSchemaVersion();

  StatusOr<int> SchemaVersion() override;
  StatusOr<SessionRecord> CreateSession(SessionRecord session) override;
  StatusOr<std::optional<SessionRecord>> LatestOpenSession(const std::string& robot_name) override;
  StatusOr<std::optional<SessionRecord>> FindSession(const std::string& session_id) override;
  StatusOr<std::vector<SessionRecord>> ListSessions() override;
  Status CloseSession(int64_t session_row, int64_t closed_ns) override;
  Status SetSessionAlignment(int64_t session_row, const SE3d& T_base_odom) override;
  Status SetSessionIsland(int64_t session_row, int64_t island_row,
                          const SE3d& T_island_odom) override;
  StatusOr<InsertResult> InsertKeyframe(const KeyframeRecord& keyframe) override;
  StatusOr<int64_t> LastStoredSeq(int64_t session_row) override;
  StatusOr<LastStamp> LastStoredStamp(int64_t session_row) override;
  StatusOr<uint64_t> CountKeyframes(std::optional<int64_t> session_row) override;
  // The keyframe scan, products and checkpoints are in sqlite_products.cc.
  Status ForEachKeyframe(int64_t after_id, const std::function<Status(KeyframeRecord)>& fn,
                         const KeyframeScan& scan = {}) override;
  Status PutProducts(int64_t keyframe_id, const std::string& fingerprint,
                     const std::string& data) override;
  StatusOr<std::optional<std::string>> GetProducts(int64_t keyframe_id,
                                                   const std::string& fingerprint) override;
  Status PutPlaceFeatures(int64_t keyframe_id, const std::string& fingerprint,
                          const std::string& data) override;
  StatusOr<std::optional<std::string>> GetPlaceFeatures(int64_t keyframe_id,
                                                        const std::string& fingerprint) override;
  Status DeleteAllProducts() override;
  Status PutKeyframePoses(const std::vector<KeyframePoseRecord>& poses) override;
  Status PutPlaceMatch(const PlaceMatchRecord& match) override;
  StatusOr<std::vector<PlaceMatchRecord>> ListPlaceMatches() override;
  Status PutCheckpoint(const CheckpointRecord& checkpoint) override;
  StatusOr<std::optional<CheckpointRecord>> LatestCheckpoint() override;
  // The published map (sqlite_published.cc).
  Status Publish(const MapPublication& publication) override;
  StatusOr<PublishedMap> ReadPublished() override;
  StatusOr<int64_t> PublishedVersion() override;
  Status DeleteCheckpoints() override;
  StatusOr<uint64_t> DropRawImages(int64_t before_stored_ns, int64_t keep_last) override;
  StatusOr<StorageBytes> Bytes() override;
  uint64_t DbBytes() override;

  // Connections open now: the writer and the pooled readers (bounded; tests check it).
  size_t open_connections() const;

 private:
  SqliteStore(std::string path, SqliteStoreOptions options);
  StatusOr<sqlite3*> OpenConnection() const;
  // The write connection; FailedPrecondition when read-only. Call with write_mu_ held.
  StatusOr<sqlite3*> Writer();
  Status Migrate(sqlite3* db);
  // Runs `body` in one write transaction (the write lock held, BEGIN IMMEDIATE, COMMIT when it
  // returns OK, ROLLBACK otherwise).
  Status Write(const std::function<Status(sqlite3*)>& body);
  // Runs one write statement with `bind` in its own transaction.
  Status WriteOne(const char* sql, const std::function<void(sqlite::Stmt&)>& bind,
                  const char* what);
  // The `data` of one (keyframe_id, fingerprint) row of a per-keyframe product table; empty
  // when the row is missing or was made with another fingerprint.
  StatusOr<std::optional<std::string>> ReadKeyed(const char* sql, int64_t keyframe_id,
                                                 const std::string& fingerprint,
                                                 const char* what);
  StatusOr<std::vector<SessionRecord>> QuerySessions(const std::string& where_sql,
                                                     const std::string& arg);

  std::string path_;
  SqliteStoreOptions options_;
  std::mutex write_mu_;
  sqlite3* writer_ = nullptr;  // guarded by write_mu_; null when read-only
  sqlite::ReadPool readers_;
};

}  // namespace loci::server
