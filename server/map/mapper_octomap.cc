// Mapper's OctoMap threads: new keyframes' scans go into the live tree on one thread; after a
// pose update a new tree is built from every keyframe's products on another, and the scans of
// keyframes mapped meanwhile are added to it before it replaces the live one. The mapping thread
// therefore never waits for a rebuild (which reads every keyframe's products back: seconds per
// 1000 keyframes), only for the scan queue. A rebuild runs to its end even when a newer pose
// update comes meanwhile (which then waits, the newest of them only): were it dropped for the
// newer one, pose updates coming faster than a rebuild takes would never let one finish.
#include <spdlog/spdlog.h>

#include <unordered_set>

#include "common/time.h"
#include "server/map/map_points.h"
#include "server/map/mapper.h"

namespace loci::server {

void Mapper::OctomapLoop() {
  while (std::optional<OctomapScan> scan = octomap_queue_.Pop()) {
    const double t0 = ThreadCpuMs();
    {
      std::lock_guard<std::mutex> lock(octo_mu_);
      octomap_->Insert(scan->points_m, scan->origin_m);
      if (collecting_scans_) scans_since_request_.push_back(std::move(*scan));
    }
    const double ms = ThreadCpuMs() - t0;
    {
      std::lock_guard<std::mutex> lock(mu_);
      stats_.total.octomap_ms += ms;
    }
    std::lock_guard<std::mutex> lock(octomap_progress_mu_);
    ++octomap_done_;
    octomap_progress_cv_.notify_all();
  }
}

void Mapper::CollectScansForRebuild() {
  std::lock_guard<std::mutex> lock(octo_mu_);
  collecting_scans_ = true;
}

void Mapper::RequestRebuild(OctomapRebuild rebuild) {
  {
    std::lock_guard<std::mutex> lock(rebuild_mu_);
    rebuild_request_ = std::move(rebuild);  // an older request not yet started is moot
  }
  rebuild_cv_.notify_all();
}

void Mapper::RebuildLoop() {
  while (true) {
    OctomapRebuild rebuild;
    {
      std::unique_lock<std::mutex> lock(rebuild_mu_);
      rebuild_cv_.wait(lock, [&] { return rebuild_stop_ || rebuild_request_.has_value(); });
      if (rebuild_stop_) return;
      rebuild = std::move(*rebuild_request_);
      rebuild_request_.reset();
    }
    const double t0 = ThreadCpuMs();
    RebuildOctomap(rebuild);
    const double ms = ThreadCpuMs() - t0;
    std::lock_guard<std::mutex> lock(mu_);
    stats_.total.octomap_ms += ms;
  }
}

void Mapper::RebuildOctomap(const OctomapRebuild& rebuild) {
  auto tree = std::make_unique<OccupancyMap>(options_.octomap);
  std::unordered_set<int64_t> in_list;
  size_t skipped = 0;
  for (const auto& [id, T_map_kf] : rebuild.T_map_kf) {
    if (rebuild_stopping_.load()) return;  // the mapper goes (its product source may be gone)
    in_list.insert(id);
    StatusOr<KeyframeProducts> products = rebuild.source(id);
    if (!products.ok()) {
      ++skipped;
      continue;
    }
    const OctomapScan scan = ThinScan(StaticPointsMap(*products, T_map_kf.cast<float>(), {}),
                                      T_map_kf.translation(), options_.octomap.resolution_m);
    tree->Insert(scan.points_m, scan.origin_m);
  }
  if (skipped > 0) {
    spdlog::warn("OctoMap rebuilt without {} of {} keyframes (their products are missing)",
                 skipped, rebuild.T_map_kf.size());
  }
  {
    std::lock_guard<std::mutex> lock(octo_mu_);
    for (const OctomapScan& scan : scans_since_request_) {
      if (!in_list.count(scan.keyframe_id)) tree->Insert(scan.points_m, scan.origin_m);
    }
    // A newer request waits: its list holds what this one's does and more, and it still needs
    // the scans collected since this one's.
    if (rebuild.generation == octomap_generation_.load()) {
      scans_since_request_.clear();
      collecting_scans_ = false;
    }
    octomap_ = std::move(tree);
  }
  std::lock_guard<std::mutex> lock(octomap_progress_mu_);
  rebuilt_generation_ = rebuild.generation;
  octomap_progress_cv_.notify_all();
}

void Mapper::FlushOctomap(bool wait_for_rebuild) const {
  // Waits for the scans pushed and the rebuild requested before this call only: a reader must
  // not wait for keyframes the worker maps meanwhile (under a steady stream that wait would
  // never end).
  std::unique_lock<std::mutex> lock(octomap_progress_mu_);
  const uint64_t target = octomap_pushed_;
  const uint64_t generation =
      options_.octomap.enabled && wait_for_rebuild ? octomap_generation_.load() : 0;
  octomap_progress_cv_.wait(lock, [&] {
    return octomap_done_ >= target && rebuilt_generation_ >= generation;
  });
}

bool Mapper::OctomapRebuilding() const {
  if (!options_.octomap.enabled) return false;
  std::lock_guard<std::mutex> lock(octomap_progress_mu_);
  return rebuilt_generation_ < octomap_generation_.load();
}

}  // namespace loci::server
