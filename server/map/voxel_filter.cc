#include "server/map/voxel_filter.h"

#include <pcl/point_types.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>
#include <unordered_map>
#include <vector>

#include "server/map/voxel_key.h"

namespace loci::server {
namespace {

constexpr uint64_t kEmpty = std::numeric_limits<uint64_t>::max();

struct Accumulator {
  double x = 0, y = 0, z = 0;
  uint32_t r = 0, g = 0, b = 0;
  uint32_t count = 0;
  uint32_t label = 0, label_count = 0;  // the first label seen and its count (others: apart)
};

}  // namespace

template <typename PointT>
pcl::PointCloud<PointT> VoxelAverage(const pcl::PointCloud<PointT>& cloud, double voxel_m) {
  if (!(voxel_m > 0) || cloud.empty()) return cloud;
  constexpr bool kLabelled = std::is_same_v<PointT, pcl::PointXYZRGBL>;
  const float inv = static_cast<float>(1.0 / voxel_m);
  size_t cap = 64;
  while (cap < 2 * cloud.size()) cap <<= 1;
  const size_t mask = cap - 1;
  std::vector<uint64_t> keys(cap, kEmpty);
  std::vector<uint32_t> slot_acc(cap);
  std::vector<Accumulator> acc;
  acc.reserve(cloud.size() / 4 + 16);
  // (accumulator << 32 | label) -> count, for the rare voxels holding several labels.
  std::unordered_map<uint64_t, uint32_t> others;
  for (const PointT& p : cloud) {
    auto cell = [inv](float v) { return static_cast<int64_t>(std::floor(v * inv)); };
    const VoxelKey key = PackVoxel(cell(p.x), cell(p.y), cell(p.z));
    size_t slot = HashVoxelKey(key) & mask;
    while (keys[slot] != kEmpty && keys[slot] != key) slot = (slot + 1) & mask;
    if (keys[slot] == kEmpty) {
      keys[slot] = key;
      slot_acc[slot] = static_cast<uint32_t>(acc.size());
      acc.emplace_back();
    }
    const uint32_t ai = slot_acc[slot];
    Accumulator& a = acc[ai];
    a.x += p.x;
    a.y += p.y;
    a.z += p.z;
    a.r += p.r;
    a.g += p.g;
    a.b += p.b;
    ++a.count;
    if constexpr (kLabelled) {
      if (a.label_count == 0 || a.label == p.label) {
        a.label = p.label;
        ++a.label_count;
      } else {
        ++others[(static_cast<uint64_t>(ai) << 32) | p.label];
      }
    }
  }
  std::vector<std::pair<uint32_t, uint32_t>> majority;  // accumulator -> (label, count)
  if constexpr (kLabelled) {
    majority.resize(acc.size());
    for (size_t i = 0; i < acc.size(); ++i) majority[i] = {acc[i].label, acc[i].label_count};
    for (const auto& [k, n] : others) {
      auto& [label, count] = majority[k >> 32];
      const uint32_t l = static_cast<uint32_t>(k & 0xffffffffu);
      if (n > count || (n == count && l < label)) {
        label = l;
        count = n;
      }
    }
  }
  pcl::PointCloud<PointT> out;
  out.resize(acc.size());
  for (size_t i = 0; i < acc.size(); ++i) {
    const Accumulator& a = acc[i];
    PointT& q = out[i];
    const double n = a.count;
    q.x = static_cast<float>(a.x / n);
    q.y = static_cast<float>(a.y / n);
    q.z = static_cast<float>(a.z / n);
    q.r = static_cast<uint8_t>(a.r / a.count);
    q.g = static_cast<uint8_t>(a.g / a.count);
    q.b = static_cast<uint8_t>(a.b / a.count);
    if constexpr (kLabelled) q.label = majority[i].first;
  }
  out.width = static_cast<uint32_t>(out.size());
  out.height = 1;
  out.is_dense = true;
  return out;
}

template pcl::PointCloud<pcl::PointXYZRGBL> VoxelAverage(const pcl::PointCloud<pcl::PointXYZRGBL>&,
                                                         double);
template pcl::PointCloud<pcl::PointXYZRGB> VoxelAverage(const pcl::PointCloud<pcl::PointXYZRGB>&,
                                                        double);

}  // namespace loci::server
