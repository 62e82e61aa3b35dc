// The map's OctoMap on its own two threads. New keyframes' scans go into the live tree on one
// (Push returns once the scan is queued; the queue holds 8); after a pose update a new tree is
// built from every keyframe's products on the other, and the scans of keyframes mapped
// meanwhile are added to it before it replaces the live one. The mapping thread therefore never
// waits for a rebuild (which reads every keyframe's products back: seconds per 1000 keyframes),
// only for the scan queue. A rebuild runs to its end even when a newer pose update comes
// meanwhile (which then waits, the newest of them only): were it dropped for the newer one,
// pose updates coming faster than a rebuild takes would never let one finish. Readers take the
// tree under its own lock, so ray casting does not block the map's other queries.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "common/bounded_queue.h"
#include "common/se3.h"
#include "common/status.h"
#include "server/map/keyframe_products.h"
#include "server/map/map_options.h"
#include "server/map/occupancy_map.h"
#include "server/map/semantic_cloud.h"

namespace loci::server {

// One keyframe's rays: its static points thinned to one per OctoMap leaf, and its camera centre.
struct OctomapScan {
  int64_t keyframe_id = 0;
  std::vector<Eigen::Vector3f> points_m;  // map frame
  Vec3d origin_m = Vec3d::Zero();
};

// The scan of `static_points_m` (map frame) seen from origin_m: one ray per leaf is enough.
OctomapScan ThinScan(const std::vector<SemanticPoint>& static_points_m, const Vec3d& origin_m,
                     double resolution_m);

class LiveOctomap {
 public:
  // A keyframe's products (the store); empty products leave the keyframe out of a rebuild.
  using ProductSource = std::function<StatusOr<KeyframeProducts>(int64_t keyframe_id)>;
  // A new tree from every keyframe's products at these poses (after a pose update).
  struct Rebuild {
    std::vector<std::pair<int64_t, SE3d>> T_map_kf;  // keyframe id, pose; in id order
    ProductSource source;                            // valid until the rebuild is in
    uint64_t generation = 0;                         // from BeginRebuild
  };

  // Starts both threads.
  explicit LiveOctomap(const OctomapOptions& options);
  // A running rebuild stops at its next keyframe (its product source may be gone).
  ~LiveOctomap();
  LiveOctomap(const LiveOctomap&) = delete;
  LiveOctomap& operator=(const LiveOctomap&) = delete;

  void Push(OctomapScan scan);
  // When a rebuild's keyframe list is taken: scans inserted from now on are also kept for the
  // new tree. The rebuild's generation.
  uint64_t BeginRebuild();
  // The rebuild runs once the one running (if any) is in; a newer request replaces this one
  // until it starts.
  void RequestRebuild(Rebuild rebuild);
  // Blocks until the tree holds every scan pushed before the call and (with wait_for_rebuild)
  // the rebuild begun before it is in. Scans pushed meanwhile are not waited for.
  void Flush(bool wait_for_rebuild) const;
  // Whether a begun rebuild is not in yet.
  bool Rebuilding() const;
  // An empty tree (the map frame was re-fixed).
  void Clear();

  std::string SerializeBt() const;
  std::string SerializeState() const;
  Status LoadState(const std::string& bytes);
  std::vector<Eigen::Vector3d> OccupiedCenters() const;
  uint64_t node_count() const;
  // Scans pushed and not inserted yet.
  uint64_t pending_scans() const;
  // Thread CPU spent inserting scans and rebuilding, ms.
  double cpu_ms() const;

 private:
  void InsertLoop();
  void RebuildLoop();
  // Builds the tree of `rebuild` and swaps it in (not when stopping).
  void RunRebuild(const Rebuild& rebuild);
  // The new tree from the rebuild's keyframes, with the ids it holds; null when stopping.
  std::unique_ptr<OccupancyMap> BuildTree(const Rebuild& rebuild, std::vector<int64_t>* ids);
  void AddCpuMs(double ms);

  const OctomapOptions options_;

  mutable std::mutex tree_mu_;  // taken before mu_ when both are held
  std::unique_ptr<OccupancyMap> tree_;       // guarded by tree_mu_; never null
  bool collecting_scans_ = false;            // guarded by tree_mu_
  std::vector<OctomapScan> scans_since_begin_;  // guarded by tree_mu_: for the new tree

  // Progress and requests: everything below is guarded by mu_ and signalled by cv_.
  mutable std::mutex mu_;
  mutable std::condition_variable cv_;
  uint64_t pushed_ = 0, inserted_ = 0;
  uint64_t generation_ = 0;          // of the latest begun rebuild
  uint64_t rebuilt_generation_ = 0;  // of the last rebuild swapped in
  std::optional<Rebuild> request_;   // the newest not started
  bool stopping_ = false;
  double cpu_ms_ = 0;

  BoundedQueue<OctomapScan> queue_{8};
  std::thread insert_thread_;
  std::thread rebuild_thread_;
};

}  // namespace loci::server
