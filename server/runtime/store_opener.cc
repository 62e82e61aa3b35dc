#include "server/runtime/store_opener.h"

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "server/postgres/postgres_store.h"
#include "server/storage/sqlite_store.h"

namespace loci::server {
namespace {

// The URI without its password (postgresql://user:secret@host -> postgresql://user@host).
std::string Redacted(const std::string& uri) {
  const size_t scheme = uri.find("://");
  const size_t at = uri.find('@');
  if (scheme == std::string::npos || at == std::string::npos || at < scheme) return uri;
  const size_t colon = uri.find(':', scheme + 3);
  if (colon == std::string::npos || colon > at) return uri;
  return uri.substr(0, colon) + uri.substr(at);
}

}  // namespace

bool IsPostgresStore(const std::string& store) {
  return absl::StartsWith(store, "postgresql://") || absl::StartsWith(store, "postgres://") ||
         absl::StrContains(store, "dbname=") || absl::StrContains(store, "host=");
}

StatusOr<OpenedStore> OpenServerStore(const ServerOptions& options,
                                      const std::function<bool(const LeaseHolder&)>& waiting,
                                      std::function<void(const Status&)> lost) {
  OpenedStore out;
  if (!IsPostgresStore(options.store)) {
    std::string path = options.db_path;
    if (absl::StartsWith(options.store, "sqlite:")) {
      path = options.store.substr(7);
    } else if (!options.store.empty()) {
      return absl::InvalidArgumentError(absl::StrCat(
          "store '", options.store, "': use sqlite:FILE or postgresql://USER@HOST:PORT/DB"));
    }
    LOCI_ASSIGN_OR_RETURN(std::unique_ptr<SqliteStore> sqlite, SqliteStore::Open(path));
    out.store = std::move(sqlite);
    out.description = "SQLite " + path;
    return out;
  }
  PostgresStoreOptions pg_options;
  pg_options.site = options.site;
  LOCI_ASSIGN_OR_RETURN(std::unique_ptr<PostgresStore> pg,
                        PostgresStore::Open(options.store, pg_options));
  SiteLeaseOptions lease_options;
  lease_options.ttl_s = options.lease_ttl_s;
  lease_options.renew_s = options.lease_renew_s;
  LOCI_ASSIGN_OR_RETURN(out.lease,
                        SiteLease::Acquire(options.store, options.site, lease_options, waiting));
  pg->SetFence(out.lease->fence());
  out.lease->StartRenewing(std::move(lost));
  out.description = absl::StrCat("PostgreSQL ", Redacted(options.store), ", site '",
                                 options.site, "' (writer lease epoch ",
                                 out.lease->fence().epoch, ")");
  out.store = std::move(pg);
  return out;
}

StatusOr<std::shared_ptr<PostgresStore>> OpenReadOnlyStore(const ServerOptions& options,
                                                           std::string* description) {
  if (!IsPostgresStore(options.store)) {
    return absl::InvalidArgumentError(
        "a read-only query server follows a site of a PostgreSQL store: pass --store "
        "postgresql://USER@HOST:PORT/DB (SQLite has one server per file)");
  }
  PostgresStoreOptions pg_options;
  pg_options.site = options.site;
  pg_options.read_only = true;
  LOCI_ASSIGN_OR_RETURN(std::unique_ptr<PostgresStore> pg,
                        PostgresStore::Open(options.store, pg_options));
  LOCI_ASSIGN_OR_RETURN(const int version, pg->SchemaVersion());
  if (version != PostgresStore::LatestSchemaVersion()) {
    return absl::FailedPreconditionError(absl::StrCat(
        "site '", options.site, "' has schema version ", version, ", this build reads version ",
        PostgresStore::LatestSchemaVersion(), ": start the site's writer with this build first"));
  }
  *description = absl::StrCat("read-only, PostgreSQL ", Redacted(options.store), ", site '",
                              options.site, "'");
  return std::shared_ptr<PostgresStore>(std::move(pg));
}

}  // namespace loci::server
