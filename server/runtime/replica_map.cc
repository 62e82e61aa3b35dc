#include "server/runtime/replica_map.h"

#include <spdlog/spdlog.h>

#include <utility>

#include "absl/strings/str_cat.h"
#include "common/thread_name.h"
#include "common/time.h"
#include "server/runtime/proto_convert.h"
#include "server/runtime/replica_changes.h"

namespace loci::server {
namespace {

// How long one wait for a publication lasts: bounds how late a shutdown is noticed.
constexpr std::chrono::milliseconds kWait{500};
// After an error (database gone), the next try.
constexpr std::chrono::seconds kRetry{1};

StatusOr<MapObject> ObjectOf(const ObjectRecord& row) {
  if (!row.wire.empty()) {
    loci::v1::Object wire;
    if (!wire.ParseFromString(row.wire)) {
      return absl::InvalidArgumentError(absl::StrCat("object ", row.id, ": its stored form does "
                                                     "not parse as loci.v1.Object"));
    }
    return FromProto(wire);
  }
  MapObject o;
  o.id = row.id;
  o.class_name = row.class_name;
  o.confidence = row.confidence;
  o.labels = {{row.class_name, row.confidence}};
  o.confirmed = row.confirmed;
  o.centroid_m = row.centroid_m;
  o.aabb_min_m = row.min_m;
  o.aabb_max_m = row.max_m;
  o.obb_center_m = 0.5 * (row.min_m + row.max_m);
  o.obb_half_extent_m = 0.5 * (row.max_m - row.min_m);
  o.observation_count = row.observation_count;
  o.last_seen_ns = row.last_seen_ns;
  o.removed_t_ns = row.removed_t_ns;
  return o;
}

}  // namespace

StatusOr<ReplicaSnapshot> SnapshotOf(PublishedMap published) {
  ReplicaSnapshot s;
  s.version = published.version;
  s.published_ns = published.published_ns;
  s.loaded_ns = NowNs();
  for (const ObjectRecord& row : published.objects) {
    LOCI_ASSIGN_OR_RETURN(MapObject o, ObjectOf(row));
    (o.removed_t_ns == 0 ? s.objects : s.removed).push_back(std::move(o));
  }
  for (const PublishedPose& p : published.poses) s.poses[p.robot] = {p.t_ns, p.T_map_cam};
  s.up_map = published.up_map;
  s.levelled_by = std::move(published.levelled_by);
  s.last_keyframe_id = published.last_keyframe_id;
  return s;
}

ReplicaMap::ReplicaMap(std::shared_ptr<PostgresStore> store, int max_watchers)
    : store_(std::move(store)), snapshot_(std::make_shared<ReplicaSnapshot>()),
      events_(max_watchers) {
  thread_ = NamedThread("loci-replica", [this] { Run(); });
}

ReplicaMap::~ReplicaMap() {
  stop_ = true;
  stop_cv_.notify_all();
  thread_.join();
  events_.CloseAll();
}

std::shared_ptr<const ReplicaSnapshot> ReplicaMap::Snapshot() const {
  std::lock_guard<std::mutex> lock(mu_);
  return snapshot_;
}

void ReplicaMap::Run() {
  std::string last_error;
  while (!stop_) {
    // The first read does not wait: the published map as it is now makes the server ready.
    const Status s = Follow(readiness_.ready() ? kWait : std::chrono::milliseconds(0));
    if (s.ok()) {
      if (!readiness_.ready()) readiness_.Finish(absl::OkStatus());
      if (!last_error.empty()) spdlog::info("following site '{}' again", site());
      last_error.clear();
      continue;
    }
    if (s.ToString() != last_error) {  // logged once per kind of failure, not every second
      spdlog::warn("following site '{}': {}; serving the map loaded before, retrying", site(),
                   s.ToString());
      last_error = s.ToString();
    }
    std::unique_lock<std::mutex> lock(stop_mu_);
    stop_cv_.wait_for(lock, kRetry, [this] { return stop_.load(); });
  }
}

Status ReplicaMap::Follow(std::chrono::milliseconds wait) {
  const int64_t loaded = readiness_.ready() ? Snapshot()->version : -1;
  LOCI_ASSIGN_OR_RETURN(const int64_t version, store_->WaitPublished(loaded, wait));
  if (version <= loaded) return absl::OkStatus();
  LOCI_ASSIGN_OR_RETURN(PublishedMap published, store_->ReadPublished());
  LOCI_ASSIGN_OR_RETURN(ReplicaSnapshot snapshot, SnapshotOf(std::move(published)));
  auto next = std::make_shared<const ReplicaSnapshot>(std::move(snapshot));
  std::shared_ptr<const ReplicaSnapshot> before;
  {
    std::lock_guard<std::mutex> lock(mu_);
    before = std::exchange(snapshot_, next);
  }
  ++reloads_;
  // The first load is the map as it is, not a change; only this thread swaps snapshots.
  if (loaded >= 0) events_.Publish(ChangesBetween(*before, *next));
  return absl::OkStatus();
}

}  // namespace loci::server
