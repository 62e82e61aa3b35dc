// `loci migrate --from sqlite:FILE --to postgresql://... [--site NAME]`: copies a SQLite map into
// an empty site of a PostgreSQL database, keeping every id (session rows and public ids,
// keyframe ids), because products, checkpoints and place matches refer to keyframe ids and
// robots resume their sessions by id. The SQLite file is only read. The copy holds the site's
// writer lease, so no server maps the site meanwhile, and it is checked against the source
// before it counts as done.
#include <sqlite3.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "cli/commands.h"
#include "server/postgres/postgres_store.h"
#include "server/postgres/site_lease.h"
#include "server/storage/sqlite_store.h"
#include "server/storage/sqlite_util.h"

namespace loci::cli {
namespace {

using server::sqlite::SqlError;
using server::sqlite::Stmt;

// Corrected poses written per transaction.
constexpr size_t kPoseBatch = 500;
// A progress line every this many keyframes (and after the last).
constexpr uint64_t kProgressEvery = 100;

struct MigrateArgs {
  std::string from, to, site = "default";
};

struct MigrateCounts {
  uint64_t sessions = 0, keyframes = 0, products = 0, features = 0, poses = 0, matches = 0;
  std::optional<int64_t> checkpoint_keyframe;
};

// "sqlite:FILE" or a plain path.
std::string SqlitePath(const std::string& from) {
  const std::string scheme = "sqlite:";
  return absl::StartsWith(from, scheme) ? from.substr(scheme.size()) : from;
}

Status CheckPostgresUri(const std::string& to) {
  if (absl::StartsWith(to, "postgresql://") || absl::StartsWith(to, "postgres://") ||
      absl::StrContains(to, '=')) {
    return absl::OkStatus();
  }
  return absl::InvalidArgumentError(absl::StrCat(
      "--to '", to, "': give a postgresql:// (or postgres://) URI or a libpq key=value string"));
}

using SqliteHandle = std::unique_ptr<sqlite3, decltype(&sqlite3_close_v2)>;

// A read-only connection for the columns MapStore's records do not carry (close and store
// times) and the per-keyframe tables read by fingerprint.
StatusOr<SqliteHandle> OpenRaw(const std::string& path) {
  sqlite3* db = nullptr;
  const int rc =
      sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READONLY | SQLITE_OPEN_NOMUTEX, nullptr);
  SqliteHandle handle(db, &sqlite3_close_v2);
  if (rc != SQLITE_OK) {
    return absl::UnavailableError(
        absl::StrCat("cannot open ", path, ": ", db ? sqlite3_errmsg(db) : "no memory"));
  }
  sqlite3_busy_timeout(db, 5000);
  return handle;
}

// Runs `sql` (one int64 parameter: a row id) and returns its int64 first column, nullopt for
// no row or NULL.
StatusOr<std::optional<int64_t>> LookUpInt(sqlite3* db, Stmt& q, int64_t id,
                                           const std::string& what) {
  q.Reset();
  q.Bind(1, id);
  const int rc = q.Step();
  if (rc == SQLITE_DONE) return std::optional<int64_t>();
  if (rc != SQLITE_ROW) return SqlError(db, what);
  return q.IsNull(0) ? std::optional<int64_t>() : std::optional<int64_t>(q.Int(0));
}

// Copies every (keyframe_id, fingerprint, data) row of `table` with `put`; returns the count.
StatusOr<uint64_t> CopyKeyed(
    sqlite3* db, const std::string& table,
    const std::function<Status(int64_t, const std::string&, const std::string&)>& put) {
  const std::string sql =
      absl::StrCat("SELECT keyframe_id, fingerprint, data FROM ", table, " ORDER BY keyframe_id");
  Stmt q(db, sql.c_str());
  LOCI_RETURN_IF_ERROR(q.status());
  uint64_t n = 0;
  int rc;
  while ((rc = q.Step()) == SQLITE_ROW) {
    LOCI_RETURN_IF_ERROR(put(q.Int(0), q.Text(1), q.Text(2)));
    ++n;
  }
  if (rc != SQLITE_DONE) return SqlError(db, "read " + table);
  return n;
}

StatusOr<MigrateCounts> Copy(server::SqliteStore& src, sqlite3* raw, server::PostgresStore& dst,
                             const std::string& path) {
  MigrateCounts counts;
  LOCI_ASSIGN_OR_RETURN(std::vector<server::SessionRecord> sessions, src.ListSessions());
  {
    Stmt closed(raw, "SELECT closed_ns FROM sessions WHERE id = ?");
    LOCI_RETURN_IF_ERROR(closed.status());
    for (const server::SessionRecord& s : sessions) {
      LOCI_ASSIGN_OR_RETURN(std::optional<int64_t> closed_ns,
                            LookUpInt(raw, closed, s.row_id, "read session close time"));
      LOCI_RETURN_IF_ERROR(dst.ImportSession(s, closed_ns));
      ++counts.sessions;
    }
  }

  LOCI_ASSIGN_OR_RETURN(const uint64_t total, src.CountKeyframes(std::nullopt));
  Stmt stored(raw, "SELECT stored_ns FROM keyframes WHERE id = ?");
  LOCI_RETURN_IF_ERROR(stored.status());
  std::vector<server::KeyframePoseRecord> poses;
  auto flush_poses = [&]() -> Status {
    if (poses.empty()) return absl::OkStatus();
    LOCI_RETURN_IF_ERROR(dst.PutKeyframePoses(poses));
    counts.poses += poses.size();
    poses.clear();
    return absl::OkStatus();
  };
  server::KeyframeScan scan;  // images and detections, no products (copied by fingerprint)
  scan.images = true;
  const Status scanned = src.ForEachKeyframe(
      0,
      [&](server::KeyframeRecord kf) -> Status {
        LOCI_ASSIGN_OR_RETURN(std::optional<int64_t> stored_ns,
                              LookUpInt(raw, stored, kf.id, "read keyframe store time"));
        if (!stored_ns) {
          return absl::InternalError(absl::StrCat(path, ": keyframe ", kf.id, " vanished"));
        }
        LOCI_RETURN_IF_ERROR(dst.ImportKeyframe(kf, *stored_ns));
        // A corrected pose refers to its keyframe, which is stored by now.
        if (kf.T_base_kf_corrected) {
          poses.push_back({kf.id, *kf.T_base_kf_corrected});
          if (poses.size() >= kPoseBatch) LOCI_RETURN_IF_ERROR(flush_poses());
        }
        if (++counts.keyframes % kProgressEvery == 0 || counts.keyframes == total) {
          std::fprintf(stderr, "%llu / %llu keyframes\n",
                       static_cast<unsigned long long>(counts.keyframes),
                       static_cast<unsigned long long>(total));
        }
        return absl::OkStatus();
      },
      scan);
  LOCI_RETURN_IF_ERROR(scanned);
  LOCI_RETURN_IF_ERROR(flush_poses());

  LOCI_ASSIGN_OR_RETURN(counts.products, CopyKeyed(raw, "keyframe_products",
                                                   [&](int64_t id, const std::string& fingerprint,
                                                       const std::string& data) {
                                                     return dst.PutProducts(id, fingerprint, data);
                                                   }));
  LOCI_ASSIGN_OR_RETURN(
      counts.features,
      CopyKeyed(raw, "place_features",
                [&](int64_t id, const std::string& fingerprint, const std::string& data) {
                  return dst.PutPlaceFeatures(id, fingerprint, data);
                }));
  LOCI_ASSIGN_OR_RETURN(std::vector<server::PlaceMatchRecord> matches, src.ListPlaceMatches());
  for (const server::PlaceMatchRecord& m : matches) {
    LOCI_RETURN_IF_ERROR(dst.PutPlaceMatch(m));
    ++counts.matches;
  }
  LOCI_ASSIGN_OR_RETURN(std::optional<server::CheckpointRecord> checkpoint, src.LatestCheckpoint());
  if (checkpoint) {
    LOCI_RETURN_IF_ERROR(dst.PutCheckpoint(*checkpoint));
    counts.checkpoint_keyframe = checkpoint->last_keyframe_id;
  }
  LOCI_ASSIGN_OR_RETURN(server::PublishedMap published, src.ReadPublished());
  if (published.version > 0) {  // the object table as its writer last published it
    server::MapPublication whole;
    whole.replace_all = true;
    whole.objects = std::move(published.objects);
    whole.poses = std::move(published.poses);
    whole.up_map = published.up_map;
    whole.levelled_by = std::move(published.levelled_by);
    whole.last_keyframe_id = published.last_keyframe_id;
    LOCI_RETURN_IF_ERROR(dst.Publish(whole));
  }
  LOCI_RETURN_IF_ERROR(dst.FinishImport());
  return counts;
}

// The copy against the source: the same number of every kind of record.
Status Verify(server::SqliteStore& src, server::PostgresStore& dst, const std::string& site) {
  LOCI_ASSIGN_OR_RETURN(const uint64_t src_keyframes, src.CountKeyframes(std::nullopt));
  LOCI_ASSIGN_OR_RETURN(const uint64_t dst_keyframes, dst.CountKeyframes(std::nullopt));
  LOCI_ASSIGN_OR_RETURN(const std::vector<server::SessionRecord> src_sessions, src.ListSessions());
  LOCI_ASSIGN_OR_RETURN(const std::vector<server::SessionRecord> dst_sessions, dst.ListSessions());
  LOCI_ASSIGN_OR_RETURN(const server::StorageBytes src_bytes, src.Bytes());
  LOCI_ASSIGN_OR_RETURN(const server::StorageBytes dst_bytes, dst.Bytes());
  if (src_keyframes != dst_keyframes || src_sessions.size() != dst_sessions.size() ||
      src_bytes.products != dst_bytes.products ||
      src_bytes.place_features != dst_bytes.place_features) {
    return absl::DataLossError(absl::StrCat(
        "site '", site, "' does not match the source after the copy: ", dst_sessions.size(), " of ",
        src_sessions.size(), " sessions, ", dst_keyframes, " of ", src_keyframes, " keyframes, ",
        dst_bytes.products, " of ", src_bytes.products, " products, ", dst_bytes.place_features,
        " of ", src_bytes.place_features, " place features"));
  }
  return absl::OkStatus();
}

Status Migrate(const MigrateArgs& a) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::string path = SqlitePath(a.from);
  LOCI_RETURN_IF_ERROR(CheckPostgresUri(a.to));
  if (!std::filesystem::is_regular_file(path)) {
    return absl::NotFoundError(absl::StrCat("--from: no SQLite map at ", path));
  }
  server::SqliteStoreOptions read_only;
  read_only.read_only = true;
  LOCI_ASSIGN_OR_RETURN(std::unique_ptr<server::SqliteStore> src,
                        server::SqliteStore::Open(path, read_only));
  // Reading with this build's columns needs the file at this build's schema.
  LOCI_ASSIGN_OR_RETURN(const int version, src->SchemaVersion());
  if (version != server::SqliteStore::LatestSchemaVersion()) {
    return absl::FailedPreconditionError(
        absl::StrCat(path, " has schema version ", version, ", this build reads version ",
                     server::SqliteStore::LatestSchemaVersion(),
                     version == 0 ? " (not a loci map?)"
                                  : ": open it once with this build's loci-server to upgrade it"));
  }
  LOCI_ASSIGN_OR_RETURN(SqliteHandle raw, OpenRaw(path));

  server::PostgresStoreOptions site;
  site.site = a.site;
  LOCI_ASSIGN_OR_RETURN(std::unique_ptr<server::PostgresStore> dst,
                        server::PostgresStore::Open(a.to, site));
  // The writer lease keeps servers off the site during the copy; one that holds it now is
  // mapping the site, which is then not ours to fill.
  server::LeaseHolder holder;
  auto lease = server::SiteLease::Acquire(a.to, a.site, server::SiteLeaseOptions{},
                                          [&](const server::LeaseHolder& h) {
                                            holder = h;
                                            return false;
                                          });
  if (absl::IsCancelled(lease.status())) {
    return absl::FailedPreconditionError(
        absl::StrCat("site '", a.site, "' is being mapped by a server (", holder.holder,
                     holder.address.empty() ? "" : " at " + holder.address,
                     "): stop it before migrating into the site"));
  }
  LOCI_RETURN_IF_ERROR(lease.status());
  dst->SetFence((*lease)->fence());
  (*lease)->StartRenewing([](const Status&) {});  // a lost lease fails the next write

  LOCI_ASSIGN_OR_RETURN(const std::vector<server::SessionRecord> existing, dst->ListSessions());
  LOCI_ASSIGN_OR_RETURN(const uint64_t existing_keyframes, dst->CountKeyframes(std::nullopt));
  if (!existing.empty() || existing_keyframes > 0) {
    return absl::FailedPreconditionError(
        absl::StrCat("site '", a.site, "' already holds a map (", existing.size(), " sessions, ",
                     existing_keyframes, " keyframes): migrate only into an empty site"));
  }

  StatusOr<MigrateCounts> counts = Copy(*src, raw.get(), *dst, path);
  Status done = counts.status();
  if (done.ok()) done = Verify(*src, *dst, a.site);
  if (!done.ok()) {
    LOCI_ASSIGN_OR_RETURN(const std::string schema, server::PostgresStore::SchemaOfSite(a.site));
    return absl::Status(done.code(), absl::StrCat(done.message(), "; site '", a.site,
                                                  "' now holds a partial copy: drop it "
                                                  "(DROP SCHEMA ",
                                                  schema, " CASCADE) before migrating again"));
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const std::string checkpoint =
      counts->checkpoint_keyframe
          ? absl::StrCat("checkpoint at keyframe ", *counts->checkpoint_keyframe)
          : std::string("no checkpoint");
  std::printf(
      "migrated %llu sessions, %llu keyframes (%llu with products, %llu with place "
      "features, %llu corrected poses, %llu matches, %s) from %s to site %s in %.1f s\n",
      static_cast<unsigned long long>(counts->sessions),
      static_cast<unsigned long long>(counts->keyframes),
      static_cast<unsigned long long>(counts->products),
      static_cast<unsigned long long>(counts->features),
      static_cast<unsigned long long>(counts->poses),
      static_cast<unsigned long long>(counts->matches), checkpoint.c_str(), path.c_str(),
      a.site.c_str(), s);
  return absl::OkStatus();
}

}  // namespace

void RegisterMigrateCommand(CLI::App& app) {
  auto args = std::make_shared<MigrateArgs>();
  CLI::App* c = app.add_subcommand(
      "migrate", "copy a SQLite map into an empty PostgreSQL site, keeping every id");
  c->add_option("--from", args->from, "sqlite:FILE or FILE: the map to copy (only read)")
      ->required();
  c->add_option("--to", args->to, "postgresql://user@host:port/db (or a libpq key=value string)")
      ->required();
  c->add_option("--site", args->site, "the site to fill; it must be empty")->capture_default_str();
  c->callback([args] {
    const Status s = Migrate(*args);
    if (!s.ok()) std::cerr << "error: " << s.message() << "\n";
    ExitCode() = s.ok() ? 0 : 1;
  });
}

}  // namespace loci::cli
