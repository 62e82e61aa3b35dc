#include "server/runtime/map_publisher.h"

#include <spdlog/spdlog.h>

#include <chrono>

#include "absl/strings/str_cat.h"
#include "common/thread_name.h"
#include "server/runtime/proto_convert.h"

namespace loci::server {
namespace {

// What besides the objects a publication carries, as one comparable string.
std::string StateKey(const MapPublication& p) {
  std::string key = absl::StrCat(p.last_keyframe_id, "|", p.levelled_by, "|");
  if (p.up_map) absl::StrAppend(&key, p.up_map->x(), ",", p.up_map->y(), ",", p.up_map->z());
  for (const PublishedPose& pose : p.poses) absl::StrAppend(&key, "|", pose.robot, "@", pose.t_ns);
  return key;
}

}  // namespace

ObjectRecord ObjectRow(const MapObject& o) {
  loci::v1::Object wire;
  ToProto(o, &wire);
  return ObjectRecord{.id = o.id,
                      .class_name = o.class_name,
                      .confidence = o.confidence,
                      .confirmed = o.confirmed,
                      .centroid_m = o.centroid_m,
                      .min_m = o.aabb_min_m,
                      .max_m = o.aabb_max_m,
                      .observation_count = o.observation_count,
                      .last_seen_ns = o.last_seen_ns,
                      .removed_t_ns = o.removed_t_ns,
                      .wire = wire.SerializeAsString()};
}

MapPublication WholePublication(const Mapper& mapper) {
  MapPublication p;
  p.replace_all = true;
  // The poses first: a keyframe landing in between shows in the next publication.
  for (const auto& [robot, pose] : mapper.LatestPoses()) {
    p.poses.push_back({robot, pose.t_ns, pose.T_map_cam});
  }
  p.last_keyframe_id = mapper.last_keyframe_id();
  for (const MapObject& o : mapper.Snapshot()) {
    if (o.island.empty()) p.objects.push_back(ObjectRow(o));
  }
  for (const MapObject& o : mapper.Removed()) p.objects.push_back(ObjectRow(o));
  p.up_map = mapper.UpDirection();
  p.levelled_by = mapper.FrameSource();
  return p;
}

MapPublisher::MapPublisher(const std::unique_ptr<Mapper>& mapper, MapStore* store, const Readiness& readiness,
                           double interval_s)
    : mapper_(mapper), store_(store), readiness_(readiness), interval_s_(interval_s) {
  thread_ = NamedThread("loci-publish", [this] { Run(); });
}

MapPublisher::~MapPublisher() {
  {
    std::lock_guard<std::mutex> lock(stop_mu_);
    stop_ = true;
  }
  stop_cv_.notify_all();
  thread_.join();
}

void MapPublisher::Run() {
  const auto interval = std::chrono::duration<double>(interval_s_);
  std::unique_lock<std::mutex> lock(stop_mu_);
  while (!stop_cv_.wait_for(lock, interval, [this] { return stop_; })) {
    if (!readiness_.ready()) continue;
    lock.unlock();
    if (Status s = Flush(); !s.ok()) spdlog::warn("publishing the object table: {}", s.ToString());
    lock.lock();
  }
}

Status MapPublisher::Flush() {
  if (!readiness_.ready()) return absl::OkStatus();  // a loading map is not published
  std::lock_guard<std::mutex> lock(publish_mu_);
  return PublishChanges();
}

Status MapPublisher::PublishChanges() {
  MapPublication whole = WholePublication(*mapper_);
  const std::string state = StateKey(whole);
  std::map<int64_t, std::string> now;
  MapPublication changes;
  changes.replace_all = !published_once_;
  for (ObjectRecord& o : whole.objects) {
    now[o.id] = o.wire;
    const auto it = published_.find(o.id);
    if (changes.replace_all || it == published_.end() || it->second != o.wire) {
      changes.objects.push_back(std::move(o));
    }
  }
  for (const auto& [id, wire] : published_) {
    if (!now.contains(id)) changes.gone_ids.push_back(id);
  }
  if (published_once_ && changes.objects.empty() && changes.gone_ids.empty() &&
      state == published_state_) {
    return absl::OkStatus();
  }
  changes.poses = std::move(whole.poses);
  changes.up_map = whole.up_map;
  changes.levelled_by = std::move(whole.levelled_by);
  changes.last_keyframe_id = whole.last_keyframe_id;
  LOCI_RETURN_IF_ERROR(store_->Publish(changes));
  published_ = std::move(now);
  published_state_ = state;
  published_once_ = true;
  ++publications_;
  return absl::OkStatus();
}

uint64_t MapPublisher::publications() const { return publications_; }

}  // namespace loci::server
