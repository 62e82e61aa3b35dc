#include "server/map/semantic_cloud.h"

namespace loci::server {

void SemanticCloud::Add(const std::vector<SemanticPoint>& points_m) {
  for (const SemanticPoint& sp : points_m) {
    Voxel& v = voxels_[KeyOf(sp.p_m.cast<double>(), voxel_m_)];
    v.sum_m += sp.p_m;
    v.rgb_sum += Eigen::Vector3f((sp.rgb >> 16) & 0xff, (sp.rgb >> 8) & 0xff, sp.rgb & 0xff);
    ++v.count;
    if (v.votes == 0) {
      v.object_id = sp.object_id;
      v.votes = 1;
    } else {
      v.votes += (v.object_id == sp.object_id) ? 1 : -1;
    }
  }
}

void SemanticCloud::Remove(const std::vector<SemanticPoint>& points_m) {
  for (const SemanticPoint& sp : points_m) {
    auto it = voxels_.find(KeyOf(sp.p_m.cast<double>(), voxel_m_));
    if (it == voxels_.end()) continue;
    Voxel& v = it->second;
    if (--v.count == 0) {
      voxels_.erase(it);
      continue;
    }
    v.sum_m -= sp.p_m;
    v.rgb_sum -= Eigen::Vector3f((sp.rgb >> 16) & 0xff, (sp.rgb >> 8) & 0xff, sp.rgb & 0xff);
    if (v.object_id == sp.object_id && v.votes > 0) --v.votes;
  }
}

std::vector<SemanticPoint> SemanticCloud::Points(double voxel_m,
                                                 const std::function<int64_t(int64_t)>& resolve,
                                                 const std::function<bool(int64_t)>& keep) const {
  auto to_point = [&](const Voxel& v) {
    const Eigen::Vector3f rgb = v.rgb_sum / static_cast<float>(v.count);
    SemanticPoint p;
    p.p_m = v.sum_m / static_cast<float>(v.count);
    p.rgb = (static_cast<uint32_t>(rgb.x()) << 16) | (static_cast<uint32_t>(rgb.y()) << 8) |
            static_cast<uint32_t>(rgb.z());
    p.object_id = v.object_id == 0 ? 0 : resolve(v.object_id);
    return p;
  };
  std::vector<SemanticPoint> out;
  if (voxel_m <= voxel_m_ * 1.0001) {
    out.reserve(voxels_.size());
    for (const auto& [key, v] : voxels_) {
      SemanticPoint p = to_point(v);
      if (keep(p.object_id)) out.push_back(p);
    }
    return out;
  }
  // Coarser: average the kept voxels of each coarse voxel; the id of its first labelled voxel.
  VoxelMap<Voxel> coarse;
  for (const auto& [key, v] : voxels_) {
    SemanticPoint p = to_point(v);
    if (!keep(p.object_id)) continue;
    Voxel& c = coarse[KeyOf(p.p_m.cast<double>(), voxel_m)];
    c.sum_m += p.p_m;
    c.rgb_sum += v.rgb_sum / static_cast<float>(v.count);
    ++c.count;
    if (c.object_id == 0) c.object_id = p.object_id;
  }
  out.reserve(coarse.size());
  for (const auto& [key, c] : coarse) {
    SemanticPoint p = to_point(c);
    p.object_id = c.object_id;
    out.push_back(p);
  }
  return out;
}

}  // namespace loci::server
