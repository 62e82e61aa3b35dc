// Opens the server's map store from its options: SQLite (embedded, the default) or a site of a
// PostgreSQL database, where only the holder of the site's writer lease maps it. A second server
// for the same site waits here as a standby until the lease lapses, then takes over.
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "common/status.h"
#include "server/postgres/postgres_store.h"
#include "server/postgres/site_lease.h"
#include "server/runtime/server_options.h"
#include "server/storage/map_store.h"

namespace loci::server {

struct OpenedStore {
  std::shared_ptr<MapStore> store;
  std::unique_ptr<SiteLease> lease;  // PostgreSQL: this server's writer lease; SQLite: null
  std::string description;           // for the log: "SQLite loci.db", "PostgreSQL site a (...)"
};

// Whether `store` names a PostgreSQL database.
bool IsPostgresStore(const std::string& store);

// `waiting` is called while another server holds the site's lease; returning false gives up
// (Cancelled). Once it holds the lease, the lease renews itself and calls `lost` (from its
// thread) if it is lost anyway; the lease's fence is set on the store, so its writes stop then.
StatusOr<OpenedStore> OpenServerStore(const ServerOptions& options,
                                      const std::function<bool(const LeaseHolder&)>& waiting,
                                      std::function<void(const Status&)> lost);

// A read-only query server's store: the PostgreSQL site `options.site`, opened without the
// lease and without migrating (NotFound for a site not created yet; FailedPrecondition for a
// schema of another build: the site's writer migrates it). Also returns the description.
StatusOr<std::shared_ptr<PostgresStore>> OpenReadOnlyStore(const ServerOptions& options,
                                                           std::string* description);

}  // namespace loci::server
