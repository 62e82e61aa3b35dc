// MapStore on PostgreSQL + PostGIS: one database holds many sites, each site's map in its own
// schema (site_<name>), migrated from the checked-in schema/site/NNN_*.sql files on open; the
// public schema holds the sites and their writer leases (schema/fleet/*.sql). One write
// connection behind a mutex (a site has one writer) and a small pool of read connections.
// A writer that holds the site's lease (site_lease.h) sets its fence: from then on every write
// transaction first checks that the lease is still its own, so nothing is written after a
// takeover.
#pragma once

#include <libpq-fe.h>

#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "common/connection_pool.h"
#include "server/storage/map_store.h"

namespace loci::server {

struct PostgresStoreOptions {
  // The site (map) of the database to open: [a-z0-9_-], 1 to 40 characters (default "default").
  std::string site = "default";
  // Open read-only (query servers, exports): no migration, no writes (default false).
  bool read_only = false;
  // Read connections kept open between reads (default 4).
  int max_idle_readers = 4;
};

// The lease a write transaction must still hold (SiteLease::fence()).
struct SiteFence {
  std::string holder;
  int64_t epoch = 0;
};

class PostgresStore final : public MapStore {
 public:
  // Connects to `uri` (postgresql://user@host:port/db or a libpq key=value string), creates the
  // site when missing and migrates its schema to the latest version.
  static StatusOr<std::unique_ptr<PostgresStore>> Open(const std::string& uri,
                                                       PostgresStoreOptions options = {});
  ~PostgresStore() override;
  PostgresStore(const PostgresStore&) = delete;
  PostgresStore& operator=(const PostgresStore&) = delete;

  static int LatestSchemaVersion();
  // The schema of a site ("site_" + the name with '-' as '_'), or InvalidArgument.
  static StatusOr<std::string> SchemaOfSite(const std::string& site);
  const std::string& site() const { return options_.site; }
  // Deletes a site: its schema with every table, its lease and its row in loci_sites.
  static Status DropSite(const std::string& uri, const std::string& site);
  // Every later write checks that `fence` still holds the site's lease (nullopt: no check).
  void SetFence(std::optional<SiteFence> fence);

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
  // The keyframe scan, products, poses, matches and checkpoints are in postgres_products.cc.
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
  // The published map (postgres_published.cc); Publish notifies channel loci_map with the
  // site's name on commit.
  Status Publish(const MapPublication& publication) override;
  StatusOr<PublishedMap> ReadPublished() override;
  StatusOr<int64_t> PublishedVersion() override;
  // Waits until the published version exceeds `known` (LISTEN loci_map on a connection of its
  // own), at most `timeout`; returns the version then. One waiter at a time.
  StatusOr<int64_t> WaitPublished(int64_t known, std::chrono::milliseconds timeout);
  Status DeleteCheckpoints() override;
  StatusOr<uint64_t> DropRawImages(int64_t before_stored_ns, int64_t keep_last) override;
  StatusOr<StorageBytes> Bytes() override;
  // Size of the site's tables with their indexes and TOAST, bytes.
  uint64_t DbBytes() override;

  // Connections open now: the writer and the pooled readers.
  size_t open_connections() const;

  // --- Import (loci migrate) -------------------------------------------------------------------
  // Copies a map from another store keeping its ids, because products, checkpoints and place
  // matches refer to keyframe ids (postgres_import.cc). Meant for an empty site; each call is
  // one write transaction behind the fence, like every other write.
  //
  // Stores `s` with its own row_id and session_id; closed_ns is set exactly when !s.open.
  Status ImportSession(const SessionRecord& s, std::optional<int64_t> closed_ns);
  // Stores `kf` (images, detections, pose and metadata; not its products or corrected pose)
  // with its own id and the time it was first stored.
  Status ImportKeyframe(const KeyframeRecord& kf, int64_t stored_ns);
  // Moves the id sequences of sessions, keyframes and checkpoints past the imported ids, so
  // later inserts continue after them.
  Status FinishImport();

 private:
  PostgresStore(std::string uri, std::string schema, PostgresStoreOptions options);
  StatusOr<PGconn*> OpenConnection() const;
  StatusOr<PGconn*> Writer();
  // Creates the fleet tables and the site's schema and brings both to the latest version.
  Status Migrate(PGconn* conn);
  // Runs `body` in one write transaction: the write lock held, the fence checked, COMMIT when
  // it returns OK, ROLLBACK otherwise.
  Status Write(const std::function<Status(PGconn*)>& body);
  // Runs `body` on a pooled read connection; a connection that broke is closed, not reused.
  Status Read(const std::function<Status(PGconn*)>& body);
  Status CheckFence(PGconn* conn);
  // Inserts one keyframe row (its own id when `keep_id`, else the next one); returns the id.
  static StatusOr<int64_t> InsertKeyframeRow(PGconn* conn, const KeyframeRecord& kf,
                                             bool keep_id, int64_t stored_ns);
  StatusOr<std::vector<SessionRecord>> QuerySessions(const std::string& where_sql,
                                                     const std::string& arg);
  StatusOr<std::optional<std::string>> ReadKeyed(const std::string& table, int64_t keyframe_id,
                                                 const std::string& fingerprint);

  const std::string uri_;
  const std::string schema_;
  const PostgresStoreOptions options_;
  std::mutex write_mu_;
  PGconn* writer_ = nullptr;         // guarded by write_mu_
  std::optional<SiteFence> fence_;   // guarded by write_mu_
  mutable ConnectionPool<PGconn*> readers_;
  std::mutex listen_mu_;
  PGconn* listener_ = nullptr;  // guarded by listen_mu_; LISTENs on loci_map
};

}  // namespace loci::server
