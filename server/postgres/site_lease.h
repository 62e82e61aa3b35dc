// The lease that makes one server the writer of a site's map (public.loci_site_leases): a row
// with a holder, an epoch and an expiry. The holder renews it every renew_s on its own thread;
// another server takes it over only once it has expired, and bumps the epoch, which fences out
// the old holder's writes (PostgresStore::SetFence). A server killed with -9 stops renewing, so
// its standby takes over within ttl_s plus one retry.
#pragma once

#include <libpq-fe.h>

#include <atomic>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "common/status.h"
#include "server/postgres/postgres_store.h"

namespace loci::server {

struct SiteLeaseOptions {
  // Seconds the lease lasts after each renewal (default 6, at least 1).
  double ttl_s = 6.0;
  // Seconds between renewals, and between attempts of a waiting server (default 1.5, below
  // ttl_s).
  double renew_s = 1.5;
  // Where robots reach this server (host:port), shown to those that find the site taken.
  std::string address;
};

// Who holds a site's lease now.
struct LeaseHolder {
  std::string holder;
  std::string address;
  int64_t epoch = 0;
  double expires_in_s = 0;  // negative: expired
};

class SiteLease {
 public:
  // Waits until this process holds the lease of `site` in the database at `uri` (the site must
  // exist: PostgresStore::Open creates it). `waiting` is called once per attempt while another
  // server holds it; returning false gives up (Cancelled).
  static StatusOr<std::unique_ptr<SiteLease>> Acquire(
      const std::string& uri, const std::string& site, SiteLeaseOptions options,
      const std::function<bool(const LeaseHolder&)>& waiting);
  // The holder of `site`'s lease, if any.
  static StatusOr<std::optional<LeaseHolder>> Holder(const std::string& uri,
                                                     const std::string& site);
  // Stops renewing and lets the lease lapse at once, so a standby takes over without waiting.
  ~SiteLease();
  SiteLease(const SiteLease&) = delete;
  SiteLease& operator=(const SiteLease&) = delete;

  SiteFence fence() const { return {holder_, epoch_}; }
  // Records where robots reach this server (known once its port is bound).
  Status Announce(const std::string& address);
  // Renews on a thread until destroyed; `lost` is called once (from that thread) when a renewal
  // finds the lease taken over, or none succeeded for ttl_s.
  void StartRenewing(std::function<void(const Status&)> lost);

 private:
  SiteLease(std::string uri, std::string site, SiteLeaseOptions options, PGconn* conn,
            std::string holder, int64_t epoch);
  void RenewLoop(std::function<void(const Status&)> lost);
  Status RenewOnce();

  const std::string uri_;
  const std::string site_;
  const SiteLeaseOptions options_;
  PGconn* conn_;  // used by the renewing thread only once it runs
  const std::string holder_;
  const int64_t epoch_;
  std::mutex mu_;
  std::condition_variable wake_;
  bool stop_ = false;  // guarded by mu_
  std::thread renewer_;
};

}  // namespace loci::server
