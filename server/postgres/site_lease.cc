#include "server/postgres/site_lease.h"

#include <unistd.h>

#include <chrono>
#include <random>
#include <utility>

#include "absl/strings/str_cat.h"
#include "server/postgres/pg_util.h"

namespace loci::server {
namespace {

using pg::Exec;
using pg::Params;
using pg::Result;

std::string MakeHolderId() {
  char host[256] = {};
  gethostname(host, sizeof(host) - 1);
  std::random_device os;
  return absl::StrCat(host, ":", getpid(), ":", absl::Hex(os(), absl::kZeroPad8));
}

std::chrono::milliseconds Ms(double s) {
  return std::chrono::milliseconds(static_cast<int64_t>(s * 1000.0));
}

}  // namespace

SiteLease::SiteLease(std::string uri, std::string site, SiteLeaseOptions options, PGconn* conn,
                     std::string holder, int64_t epoch)
    : uri_(std::move(uri)),
      site_(std::move(site)),
      options_(std::move(options)),
      conn_(conn),
      holder_(std::move(holder)),
      epoch_(epoch) {}

StatusOr<std::optional<LeaseHolder>> SiteLease::Holder(const std::string& uri,
                                                       const std::string& site) {
  LOCI_ASSIGN_OR_RETURN(PGconn * conn, pg::Connect(uri, ""));
  auto r = Exec(conn,
                "SELECT holder, address, epoch, EXTRACT(EPOCH FROM expires_at - now())::float8"
                " FROM public.loci_site_leases WHERE site = $1",
                Params().Text(site), "read the site lease");
  PQfinish(conn);
  if (!r.ok()) return r.status();
  if (r->rows() == 0) return std::optional<LeaseHolder>();
  return std::optional<LeaseHolder>(
      LeaseHolder{r->Bytes(0, 0), r->Bytes(0, 1), r->Int(0, 2), r->Real(0, 3)});
}

StatusOr<std::unique_ptr<SiteLease>> SiteLease::Acquire(
    const std::string& uri, const std::string& site, SiteLeaseOptions options,
    const std::function<bool(const LeaseHolder&)>& waiting) {
  if (options.ttl_s < 1.0 || options.renew_s <= 0 || options.renew_s >= options.ttl_s) {
    return absl::InvalidArgumentError(absl::StrCat("site lease: ttl ", options.ttl_s,
                                                   " s, renewal every ", options.renew_s,
                                                   " s: need ttl >= 1 s and 0 < renewal < ttl"));
  }
  const std::string holder = MakeHolderId();
  LOCI_ASSIGN_OR_RETURN(PGconn * conn, pg::Connect(uri, ""));
  for (;;) {
    // Insert, or take over a lapsed lease (a new epoch); a live one of another holder stays.
    auto r = Exec(conn,
                  "INSERT INTO public.loci_site_leases(site, holder, address, epoch, expires_at)"
                  " VALUES($1, $2, $3, 1, now() + make_interval(secs => $4))"
                  " ON CONFLICT (site) DO UPDATE SET holder = EXCLUDED.holder,"
                  " address = EXCLUDED.address, epoch = loci_site_leases.epoch + 1,"
                  " expires_at = EXCLUDED.expires_at"
                  " WHERE loci_site_leases.expires_at < now() RETURNING epoch",
                  Params().Text(site).Text(holder).Text(options.address).Real(options.ttl_s),
                  "take the site lease");
    if (!r.ok()) {
      PQfinish(conn);
      return r.status();
    }
    if (r->rows() > 0) {
      return std::unique_ptr<SiteLease>(
          new SiteLease(uri, site, std::move(options), conn, holder, r->Int(0, 0)));
    }
    auto now = Holder(uri, site);
    const LeaseHolder other = (now.ok() && *now) ? **now : LeaseHolder{};
    if (!waiting(other)) {
      PQfinish(conn);
      return absl::CancelledError(absl::StrCat("gave up waiting for site '", site, "''s lease"));
    }
    std::this_thread::sleep_for(Ms(options.renew_s));
  }
}

SiteLease::~SiteLease() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    stop_ = true;
  }
  wake_.notify_all();
  if (renewer_.joinable()) renewer_.join();
  if (pg::Healthy(conn_)) {
    (void)Exec(conn_,
               "UPDATE public.loci_site_leases SET expires_at = now() - interval '1 second'"
               " WHERE site = $1 AND holder = $2 AND epoch = $3",
               Params().Text(site_).Text(holder_).Int(epoch_), "release the site lease");
  }
  PQfinish(conn_);
}

Status SiteLease::Announce(const std::string& address) {
  // Its own connection: the renewing thread owns conn_.
  LOCI_ASSIGN_OR_RETURN(PGconn * conn, pg::Connect(uri_, ""));
  auto r = Exec(conn,
                "UPDATE public.loci_site_leases SET address = $4 WHERE site = $1 AND holder = $2"
                " AND epoch = $3",
                Params().Text(site_).Text(holder_).Int(epoch_).Text(address),
                "announce the writer's address");
  PQfinish(conn);
  if (!r.ok()) return r.status();
  if (r->affected() != 1) {
    return absl::FailedPreconditionError(
        absl::StrCat("site '", site_, "': the writer lease was lost before it was announced"));
  }
  return absl::OkStatus();
}

void SiteLease::StartRenewing(std::function<void(const Status&)> lost) {
  renewer_ = std::thread([this, lost = std::move(lost)]() mutable { RenewLoop(std::move(lost)); });
}

Status SiteLease::RenewOnce() {
  if (!pg::Healthy(conn_)) {
    PQfinish(conn_);
    conn_ = nullptr;
    LOCI_ASSIGN_OR_RETURN(conn_, pg::Connect(uri_, ""));
  }
  LOCI_ASSIGN_OR_RETURN(
      Result r, Exec(conn_,
                     "UPDATE public.loci_site_leases SET expires_at = now() + make_interval(secs"
                     " => $4) WHERE site = $1 AND holder = $2 AND epoch = $3 AND expires_at >"
                     " now()",
                     Params().Text(site_).Text(holder_).Int(epoch_).Real(options_.ttl_s),
                     "renew the site lease"));
  if (r.affected() != 1) {
    return absl::FailedPreconditionError(absl::StrCat(
        "site '", site_, "': the writer lease (epoch ", epoch_, ") lapsed or was taken over"));
  }
  return absl::OkStatus();
}

void SiteLease::RenewLoop(std::function<void(const Status&)> lost) {
  auto last_ok = std::chrono::steady_clock::now();
  std::unique_lock<std::mutex> lock(mu_);
  while (!wake_.wait_for(lock, Ms(options_.renew_s), [this] { return stop_; })) {
    lock.unlock();
    const Status s = RenewOnce();
    const auto now = std::chrono::steady_clock::now();
    lock.lock();
    if (s.ok()) {
      last_ok = now;
      continue;
    }
    // A taken lease is lost at once; a database that does not answer, once the lease lapsed.
    if (s.code() == absl::StatusCode::kFailedPrecondition || now - last_ok > Ms(options_.ttl_s)) {
      lock.unlock();
      lost(s);
      return;
    }
  }
}

}  // namespace loci::server
