#include "server/map/point_components.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "server/map/voxel_key.h"

namespace loci::server {
namespace {

struct CellPart {
  Eigen::Vector3i ijk = Eigen::Vector3i::Zero();
  int part = -1;
  int points = 0;
};

using CellTable = VoxelMap<CellPart>;

Eigen::Vector3i CellOf(const Eigen::Vector3d& p_m, double cell_m) {
  return (p_m / cell_m).array().floor().cast<int>();
}

// Labels the cells reachable from `seed` with `part`; returns their point count.
int FloodPart(CellTable& cells, CellPart& seed, int part) {
  int points = 0;
  std::vector<CellPart*> stack{&seed};
  seed.part = part;
  while (!stack.empty()) {
    CellPart* c = stack.back();
    stack.pop_back();
    points += c->points;
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          const auto it = cells.find(PackVoxel(c->ijk.x() + dx, c->ijk.y() + dy, c->ijk.z() + dz));
          if (it == cells.end() || it->second.part >= 0) continue;
          it->second.part = part;
          stack.push_back(&it->second);
        }
      }
    }
  }
  return points;
}

}  // namespace

std::vector<Eigen::Vector3d> MainParts(const std::vector<Eigen::Vector3d>& pts_m, double cell_m,
                                       double min_fraction) {
  if (min_fraction <= 0 || pts_m.empty()) return pts_m;
  CellTable cells;
  std::vector<VoxelKey> key_of(pts_m.size());
  for (size_t i = 0; i < pts_m.size(); ++i) {
    const Eigen::Vector3i ijk = CellOf(pts_m[i], cell_m);
    key_of[i] = PackVoxel(ijk.x(), ijk.y(), ijk.z());
    CellPart& c = cells[key_of[i]];
    c.ijk = ijk;
    ++c.points;
  }
  std::vector<int> part_points;
  for (auto& [key, c] : cells) {
    if (c.part < 0) part_points.push_back(FloodPart(cells, c, static_cast<int>(part_points.size())));
  }
  const int largest = static_cast<int>(
      std::max_element(part_points.begin(), part_points.end()) - part_points.begin());
  const double min_points = min_fraction * static_cast<double>(pts_m.size());
  std::vector<Eigen::Vector3d> kept;
  kept.reserve(pts_m.size());
  for (size_t i = 0; i < pts_m.size(); ++i) {
    const int part = cells.at(key_of[i]).part;
    if (part == largest || part_points[part] >= min_points) kept.push_back(pts_m[i]);
  }
  return kept;
}

}  // namespace loci::server
