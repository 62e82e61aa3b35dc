#include "server/map/object_association.h"

#include <algorithm>
#include <cmath>

namespace loci::server {

double VoxelOverlap(const VoxelSet& a, const VoxelSet& b) {
  if (a.empty() && b.empty()) return 0.0;
  const auto& small = a.size() < b.size() ? a : b;
  const auto& large = a.size() < b.size() ? b : a;
  size_t inter = 0;
  for (VoxelKey k : small) inter += large.count(k);
  return static_cast<double>(inter) / static_cast<double>(a.size() + b.size() - inter);
}

double VoxelContainment(const VoxelSet& a, const VoxelSet& b) {
  if (a.empty() || b.empty()) return 0.0;
  return Within(a.size() < b.size() ? a : b, a.size() < b.size() ? b : a);
}

double Within(const VoxelSet& a, const VoxelSet& b) {
  if (a.empty()) return 0.0;
  size_t inter = 0;
  for (VoxelKey k : a) inter += b.count(k);
  return static_cast<double>(inter) / static_cast<double>(a.size());
}

VoxelSet FootprintOfKeys(const VoxelSet& keys, double voxel_m, double cell_m) {
  VoxelSet cells;
  cells.reserve(keys.size());
  for (VoxelKey k : keys) {
    Eigen::Vector3d p = CenterOf(k, voxel_m);
    p.z() = 0;
    cells.insert(KeyOf(p, cell_m));
  }
  return cells;
}

bool ObjectAssociation::IsTopClass(const std::string& class_name) const {
  return std::find(options_.top_classes.begin(), options_.top_classes.end(), class_name) !=
         options_.top_classes.end();
}

bool ObjectAssociation::FitsClass(const std::string& class_name, double size_m) const {
  if (options_.class_size_slack <= 0) return true;
  const auto it = options_.max_size_m.find(class_name);
  return it == options_.max_size_m.end() || size_m <= options_.class_size_slack * it->second;
}

bool ObjectAssociation::SizesCompatible(double half_a_m, double half_b_m) const {
  // Below 2 cm a half extent is depth noise, not size.
  const double lo = std::max(std::min(half_a_m, half_b_m), 0.02);
  return std::max(half_a_m, half_b_m) / lo <= options_.max_size_ratio;
}

bool ObjectAssociation::LabelsAllow(const AssociationView& a, const AssociationView& b) const {
  if (a.class_name == b.class_name) return true;
  if (IsTopClass(a.class_name) != IsTopClass(b.class_name)) return false;
  return SizesCompatible(a.half_size_m, b.half_size_m) &&
         FitsClass(a.class_name, 2 * b.half_size_m) && FitsClass(b.class_name, 2 * a.half_size_m);
}

double ObjectAssociation::CentroidGateM(const AssociationView& a,
                                        const AssociationView& b) const {
  const double ra = a.range_m, rb = b.range_m;
  if (options_.gate_sigmas <= 0 || ra <= 0 || rb <= 0) return options_.centroid_gate_m;
  // At the nearer one's range: a well-placed near view does not take in a far blob beside it.
  const double r = std::min(ra, rb);
  const double depth = options_.depth_sigma_at_1m * r * r, view = options_.view_sigma_rad * r;
  return std::max(options_.centroid_gate_m,
                  options_.gate_sigmas * std::sqrt(2 * (depth * depth + view * view)));
}

int ObjectAssociation::Score(const AssociationView& a, const AssociationView& b) const {
  if (!LabelsAllow(a, b)) return 0;
  const double d = (a.centroid_m - b.centroid_m).norm();
  int score = 0;
  if (a.tracks != nullptr && b.tracks != nullptr && d < options_.track_gate_m) {
    const bool shared = std::any_of(a.tracks->begin(), a.tracks->end(), [&](const auto& t) {
      return t.second != 0 && b.tracks->count(t) > 0;
    });
    score += shared ? 1 : 0;
  }
  if (d < CentroidGateM(a, b) && SizesCompatible(a.half_size_m, b.half_size_m)) ++score;
  // Containment is only worth computing for things that can touch.
  if (d < a.half_size_m + b.half_size_m + options_.overlap_voxel_m && a.keys && b.keys) {
    const bool top = IsTopClass(a.class_name) && a.footprint && b.footprint;
    const double c =
        top ? VoxelContainment(*a.footprint, *b.footprint) : VoxelContainment(*a.keys, *b.keys);
    if (c > options_.containment) ++score;
  }
  return score;
}

}  // namespace loci::server
