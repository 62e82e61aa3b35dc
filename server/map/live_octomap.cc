#include "server/map/live_octomap.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <unordered_set>

#include "common/thread_name.h"
#include "common/time.h"
#include "server/map/map_points.h"
#include "server/map/voxel_key.h"

namespace loci::server {

OctomapScan ThinScan(const std::vector<SemanticPoint>& static_points_m, const Vec3d& origin_m,
                     double resolution_m) {
  OctomapScan scan;
  scan.origin_m = origin_m;
  struct LeafSum {
    Eigen::Vector3f sum_m = Eigen::Vector3f::Zero();
    int n = 0;
  };
  VoxelMap<LeafSum> leaves;
  for (const SemanticPoint& sp : static_points_m) {
    LeafSum& leaf = leaves[KeyOf(sp.p_m.cast<double>(), resolution_m)];
    leaf.sum_m += sp.p_m;
    ++leaf.n;
  }
  scan.points_m.reserve(leaves.size());
  for (const auto& [key, leaf] : leaves) scan.points_m.push_back(leaf.sum_m / leaf.n);
  return scan;
}

LiveOctomap::LiveOctomap(const OctomapOptions& options)
    : options_(options), tree_(std::make_unique<OccupancyMap>(options)) {
  insert_thread_ = NamedThread("loci-octomap", [this] { InsertLoop(); });
  rebuild_thread_ = NamedThread("loci-rebuild", [this] { RebuildLoop(); });
}

LiveOctomap::~LiveOctomap() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    stopping_ = true;
  }
  cv_.notify_all();
  rebuild_thread_.join();
  queue_.Close();
  insert_thread_.join();
}

void LiveOctomap::Push(OctomapScan scan) {
  {
    std::lock_guard<std::mutex> lock(mu_);
    ++pushed_;
  }
  queue_.Push(std::move(scan));
}

void LiveOctomap::InsertLoop() {
  while (std::optional<OctomapScan> scan = queue_.Pop()) {
    const double t0 = ThreadCpuMs();
    {
      std::lock_guard<std::mutex> lock(tree_mu_);
      tree_->Insert(scan->points_m, scan->origin_m);
      if (collecting_scans_) scans_since_begin_.push_back(std::move(*scan));
    }
    const double ms = ThreadCpuMs() - t0;
    std::lock_guard<std::mutex> lock(mu_);
    cpu_ms_ += ms;
    ++inserted_;
    cv_.notify_all();
  }
}

uint64_t LiveOctomap::BeginRebuild() {
  uint64_t generation = 0;
  {  // First the generation: a rebuild finishing meanwhile then keeps collecting (RunRebuild).
    std::lock_guard<std::mutex> lock(mu_);
    generation = ++generation_;
  }
  std::lock_guard<std::mutex> lock(tree_mu_);
  collecting_scans_ = true;
  return generation;
}

void LiveOctomap::RequestRebuild(Rebuild rebuild) {
  {
    std::lock_guard<std::mutex> lock(mu_);
    request_ = std::move(rebuild);  // an older request not yet started is moot
  }
  cv_.notify_all();
}

void LiveOctomap::RebuildLoop() {
  while (true) {
    Rebuild rebuild;
    {
      std::unique_lock<std::mutex> lock(mu_);
      cv_.wait(lock, [&] { return stopping_ || request_.has_value(); });
      if (stopping_) return;
      rebuild = std::move(*request_);
      request_.reset();
    }
    const double t0 = ThreadCpuMs();
    RunRebuild(rebuild);
    AddCpuMs(ThreadCpuMs() - t0);
  }
}

std::unique_ptr<OccupancyMap> LiveOctomap::BuildTree(const Rebuild& rebuild,
                                                     std::vector<int64_t>* ids) {
  auto tree = std::make_unique<OccupancyMap>(options_);
  size_t skipped = 0;
  for (const auto& [id, T_map_kf] : rebuild.T_map_kf) {
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (stopping_) return nullptr;  // the mapper goes (its product source may be gone)
    }
    ids->push_back(id);
    StatusOr<KeyframeProducts> products = rebuild.source(id);
    if (!products.ok()) {
      ++skipped;
      continue;
    }
    const OctomapScan scan = ThinScan(StaticPointsMap(*products, T_map_kf.cast<float>(), {}),
                                      T_map_kf.translation(), options_.resolution_m);
    tree->Insert(scan.points_m, scan.origin_m);
  }
  if (skipped > 0) {
    spdlog::warn("OctoMap rebuilt without {} of {} keyframes (their products are missing)",
                 skipped, rebuild.T_map_kf.size());
  }
  return tree;
}

void LiveOctomap::RunRebuild(const Rebuild& rebuild) {
  std::vector<int64_t> ids;
  std::unique_ptr<OccupancyMap> tree = BuildTree(rebuild, &ids);
  if (tree == nullptr) return;
  const std::unordered_set<int64_t> in_list(ids.begin(), ids.end());
  {
    std::lock_guard<std::mutex> lock(tree_mu_);
    for (const OctomapScan& scan : scans_since_begin_) {
      if (!in_list.count(scan.keyframe_id)) tree->Insert(scan.points_m, scan.origin_m);
    }
    uint64_t latest = 0;
    {
      std::lock_guard<std::mutex> progress(mu_);
      latest = generation_;
    }
    // A newer rebuild waits: its list holds what this one's does and more, and it still needs
    // the scans collected since this one began.
    if (rebuild.generation == latest) {
      scans_since_begin_.clear();
      collecting_scans_ = false;
    }
    tree_ = std::move(tree);
  }
  std::lock_guard<std::mutex> lock(mu_);
  rebuilt_generation_ = rebuild.generation;
  cv_.notify_all();
}

void LiveOctomap::Flush(bool wait_for_rebuild) const {
  std::unique_lock<std::mutex> lock(mu_);
  const uint64_t target = pushed_;
  const uint64_t generation = wait_for_rebuild ? generation_ : 0;
  cv_.wait(lock, [&] { return inserted_ >= target && rebuilt_generation_ >= generation; });
}

bool LiveOctomap::Rebuilding() const {
  std::lock_guard<std::mutex> lock(mu_);
  return rebuilt_generation_ < generation_;
}

void LiveOctomap::Clear() {
  std::lock_guard<std::mutex> lock(tree_mu_);
  tree_ = std::make_unique<OccupancyMap>(options_);
}

std::string LiveOctomap::SerializeBt() const {
  std::lock_guard<std::mutex> lock(tree_mu_);
  return tree_->SerializeBt();
}

std::string LiveOctomap::SerializeState() const {
  std::lock_guard<std::mutex> lock(tree_mu_);
  return tree_->SerializeState();
}

Status LiveOctomap::LoadState(const std::string& bytes) {
  std::lock_guard<std::mutex> lock(tree_mu_);
  return tree_->LoadState(bytes);
}

std::vector<Eigen::Vector3d> LiveOctomap::OccupiedCenters() const {
  std::lock_guard<std::mutex> lock(tree_mu_);
  return tree_->OccupiedCenters();
}

uint64_t LiveOctomap::node_count() const {
  std::lock_guard<std::mutex> lock(tree_mu_);
  return tree_->node_count();
}

uint64_t LiveOctomap::pending_scans() const {
  std::lock_guard<std::mutex> lock(mu_);
  return pushed_ - std::min(pushed_, inserted_);
}

double LiveOctomap::cpu_ms() const {
  std::lock_guard<std::mutex> lock(mu_);
  return cpu_ms_;
}

void LiveOctomap::AddCpuMs(double ms) {
  std::lock_guard<std::mutex> lock(mu_);
  cpu_ms_ += ms;
}

}  // namespace loci::server
