#include "server/map/grid_outlier_filter.h"

#include <pcl/point_types.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "server/map/voxel_key.h"

namespace loci::server {
namespace {

constexpr uint64_t kEmpty = std::numeric_limits<uint64_t>::max();

// Cells of the grid -> runs of point indices sorted by cell; open addressing, linear probing.
class CellIndex {
 public:
  CellIndex(const std::vector<uint64_t>& point_keys) : order_(point_keys.size()) {
    std::iota(order_.begin(), order_.end(), 0u);
    std::sort(order_.begin(), order_.end(),
              [&](uint32_t a, uint32_t b) { return point_keys[a] < point_keys[b]; });
    size_t cells = 0;
    for (size_t i = 0; i < order_.size(); ++i) {
      cells += i == 0 || point_keys[order_[i]] != point_keys[order_[i - 1]];
    }
    size_t cap = 16;
    while (cap < 2 * cells) cap <<= 1;
    mask_ = cap - 1;
    keys_.assign(cap, kEmpty);
    runs_.resize(cap);
    for (size_t i = 0; i < order_.size();) {
      size_t j = i + 1;
      while (j < order_.size() && point_keys[order_[j]] == point_keys[order_[i]]) ++j;
      const uint64_t key = point_keys[order_[i]];
      size_t slot = HashVoxelKey(key) & mask_;
      while (keys_[slot] != kEmpty) slot = (slot + 1) & mask_;
      keys_[slot] = key;
      runs_[slot] = {static_cast<uint32_t>(i), static_cast<uint32_t>(j - i)};
      i = j;
    }
  }
  // Point indices of a cell: [begin, end) into order(); empty when the cell holds none.
  std::pair<const uint32_t*, const uint32_t*> Find(uint64_t key) const {
    size_t slot = HashVoxelKey(key) & mask_;
    while (keys_[slot] != kEmpty) {
      if (keys_[slot] == key) {
        const uint32_t* b = order_.data() + runs_[slot].first;
        return {b, b + runs_[slot].second};
      }
      slot = (slot + 1) & mask_;
    }
    return {nullptr, nullptr};
  }

 private:
  std::vector<uint32_t> order_;
  std::vector<uint64_t> keys_;
  std::vector<std::pair<uint32_t, uint32_t>> runs_;
  size_t mask_ = 0;
};

}  // namespace

template <typename PointT>
std::vector<float> MeanNeighbourDistances(const pcl::PointCloud<PointT>& cloud, int mean_k,
                                          double cell_m) {
  const size_t n = cloud.size();
  std::vector<float> out(n, 0.0f);
  if (n < 2 || mean_k <= 0 || !(cell_m > 0)) return out;
  // Cells of a few voxels: the K nearest neighbours of a surface point are then within the
  // 3x3x3 block around it, so one ring settles almost every point.
  cell_m *= 3.0;
  const double inv = 1.0 / cell_m;
  std::vector<Eigen::Vector3i> cell(n);
  std::vector<uint64_t> keys(n);
  for (size_t i = 0; i < n; ++i) {
    const auto& p = cloud[i];
    cell[i] = Eigen::Vector3i(static_cast<int>(std::floor(p.x * inv)),
                              static_cast<int>(std::floor(p.y * inv)),
                              static_cast<int>(std::floor(p.z * inv)));
    keys[i] = PackVoxel(cell[i].x(), cell[i].y(), cell[i].z());
  }
  const CellIndex index(keys);
  const int k = std::min<int>(mean_k, static_cast<int>(n) - 1);
  // Beyond this ring a brute-force scan is cheaper than visiting (2r + 1)^3 cells.
  constexpr int kMaxRing = 3;
  std::vector<float> best;  // squared distances, ascending, at most k
  best.reserve(k + 1);
  auto offer = [&](float d2) {
    if (static_cast<int>(best.size()) == k && d2 >= best.back()) return;
    best.insert(std::upper_bound(best.begin(), best.end(), d2), d2);
    if (static_cast<int>(best.size()) > k) best.pop_back();
  };
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f p = cloud[i].getVector3fMap();
    best.clear();
    bool done = false;
    for (int r = 0; r <= kMaxRing && !done; ++r) {
      for (int dx = -r; dx <= r; ++dx) {
        for (int dy = -r; dy <= r; ++dy) {
          const bool face = std::abs(dx) == r || std::abs(dy) == r;
          // Only the shell of Chebyshev radius r: interior cells were visited before.
          for (int dz = -r; dz <= r; dz += (face ? 1 : std::max(1, 2 * r))) {
            const auto [b, e] = index.Find(PackVoxel(
                int64_t{cell[i].x()} + dx, int64_t{cell[i].y()} + dy, int64_t{cell[i].z()} + dz));
            for (const uint32_t* j = b; j != e; ++j) {
              if (*j != i) offer((cloud[*j].getVector3fMap() - p).squaredNorm());
            }
          }
        }
      }
      // Unvisited points lie outside the (2r + 1)^3 block: at least r cells away.
      const float reach = static_cast<float>(r * cell_m);
      done = static_cast<int>(best.size()) == k && best.back() <= reach * reach;
    }
    if (!done) {  // isolated point: exact scan of the whole cloud
      best.clear();
      for (size_t j = 0; j < n; ++j) {
        if (j != i) offer((cloud[j].getVector3fMap() - p).squaredNorm());
      }
    }
    double sum = 0;
    for (float d2 : best) sum += std::sqrt(d2);
    out[i] = static_cast<float>(sum / std::max<size_t>(1, best.size()));
  }
  return out;
}

template <typename PointT>
pcl::PointCloud<PointT> RemoveOutliersOnGrid(const pcl::PointCloud<PointT>& cloud, int mean_k,
                                             double stddev_mul, double cell_m,
                                             double min_threshold_m) {
  if (mean_k <= 0 || !(cell_m > 0) || static_cast<int>(cloud.size()) <= mean_k) return cloud;
  const std::vector<float> d = MeanNeighbourDistances(cloud, mean_k, cell_m);
  // Mean and sample standard deviation as pcl::StatisticalOutlierRemoval computes them.
  double sum = 0, sq_sum = 0;
  for (float v : d) {
    sum += v;
    sq_sum += static_cast<double>(v) * v;
  }
  const double n = static_cast<double>(d.size());
  const double mean = sum / n;
  const double variance = (sq_sum - sum * sum / n) / (n - 1);
  const double threshold =
      std::max(min_threshold_m, mean + stddev_mul * std::sqrt(std::max(0.0, variance)));
  pcl::PointCloud<PointT> out;
  out.reserve(cloud.size());
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (d[i] <= threshold) out.push_back(cloud[i]);
  }
  return out;
}

template std::vector<float> MeanNeighbourDistances(const pcl::PointCloud<pcl::PointXYZRGBL>&, int,
                                                   double);
template std::vector<float> MeanNeighbourDistances(const pcl::PointCloud<pcl::PointXYZRGB>&, int,
                                                   double);
template pcl::PointCloud<pcl::PointXYZRGBL> RemoveOutliersOnGrid(
    const pcl::PointCloud<pcl::PointXYZRGBL>&, int, double, double, double);
template pcl::PointCloud<pcl::PointXYZRGB> RemoveOutliersOnGrid(
    const pcl::PointCloud<pcl::PointXYZRGB>&, int, double, double, double);

}  // namespace loci::server
