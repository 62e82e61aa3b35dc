#include "server/map/support_tops.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <unordered_map>

#include "detection/background_planes.h"

namespace loci::server {
namespace {

constexpr int64_t kCellBias = 1 << 20;

int64_t PackCell(int64_t i, int64_t j) { return (i + kCellBias) * (2 * kCellBias) + (j + kCellBias); }
void UnpackCell(int64_t key, int64_t* i, int64_t* j) {
  *i = key / (2 * kCellBias) - kCellBias;
  *j = key % (2 * kCellBias) - kCellBias;
}

// A fixed pseudo-random sequence (the same map for the same input on every platform).
class Lcg {
 public:
  size_t Next(size_t n) {
    state_ = state_ * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<size_t>((state_ >> 33) % n);
  }

 private:
  uint64_t state_ = 1;
};

// Connected regions (8-neighbourhood) of a set of footprint cells.
std::vector<std::unordered_set<int64_t>> Regions(std::unordered_set<int64_t> cells) {
  std::vector<std::unordered_set<int64_t>> regions;
  while (!cells.empty()) {
    std::unordered_set<int64_t> region;
    std::vector<int64_t> stack = {*cells.begin()};
    cells.erase(cells.begin());
    while (!stack.empty()) {
      const int64_t key = stack.back();
      stack.pop_back();
      region.insert(key);
      int64_t i = 0, j = 0;
      UnpackCell(key, &i, &j);
      for (int64_t di = -1; di <= 1; ++di) {
        for (int64_t dj = -1; dj <= 1; ++dj) {
          auto it = cells.find(PackCell(i + di, j + dj));
          if (it == cells.end()) continue;
          stack.push_back(*it);
          cells.erase(it);
        }
      }
    }
    regions.push_back(std::move(region));
  }
  return regions;
}

struct Plane {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  double offset_m = 0;
  size_t inliers = 0;
};

// The points a plane search works on: each point's footprint cell (a dense index into `cells`)
// and its plane tolerance (detection::PlaneToleranceM at its depth).
struct PlanePoints {
  const std::vector<Eigen::Vector3d>* points = nullptr;
  std::vector<int64_t> cells;      // cell keys, each once
  std::vector<int> cell_of;        // per point: index into cells
  std::vector<int> cell_size;      // per cell: points
  std::vector<double> tolerance_m; // per point
};

template <typename CellOf>
PlanePoints Prepare(const std::vector<Eigen::Vector3d>& pts, const detection::MaskOptions& mask,
                    const CellOf& cell_of) {
  PlanePoints out;
  out.points = &pts;
  std::unordered_map<int64_t, int> index;
  out.cell_of.reserve(pts.size());
  out.tolerance_m.reserve(pts.size());
  for (const Eigen::Vector3d& p : pts) {
    const auto [it, added] = index.emplace(cell_of(p), static_cast<int>(out.cells.size()));
    if (added) {
      out.cells.push_back(it->first);
      out.cell_size.push_back(0);
    }
    ++out.cell_size[it->second];
    out.cell_of.push_back(it->second);
    out.tolerance_m.push_back(detection::PlaneToleranceM(p.z(), mask));
  }
  return out;
}

// The cells on `plane` (SupportTopsOptions::cell_band_share) as flags per cell, and the plane's
// inlier count (points within their tolerance).
std::vector<char> OnPlaneCells(const PlanePoints& pp, double band_share, Plane* plane) {
  std::vector<int> tight(pp.cells.size(), 0);
  plane->inliers = 0;
  const std::vector<Eigen::Vector3d>& pts = *pp.points;
  for (size_t i = 0; i < pts.size(); ++i) {
    const double d = std::abs(plane->normal.dot(pts[i]) - plane->offset_m);
    if (d > pp.tolerance_m[i]) continue;
    ++plane->inliers;
    if (band_share <= 0 || d <= band_share * pp.tolerance_m[i]) ++tight[pp.cell_of[i]];
  }
  std::vector<char> on(pp.cells.size(), 0);
  for (size_t c = 0; c < on.size(); ++c) {
    on[c] = band_share <= 0 ? tight[c] > 0 : tight[c] > 0 && 2 * tight[c] >= pp.cell_size[c];
  }
  return on;
}

std::unordered_set<int64_t> CellKeys(const PlanePoints& pp, const std::vector<char>& on) {
  std::unordered_set<int64_t> keys;
  for (size_t c = 0; c < on.size(); ++c) {
    if (on[c]) keys.insert(pp.cells[c]);
  }
  return keys;
}

// The level plane whose largest connected footprint region is largest (RANSAC). Not the one
// with the most inliers: a plane tilted within the tolerance can cut strips out of two tops a
// few centimetres apart and hold more points than either.
Plane BestLevelPlane(const PlanePoints& pp, const Eigen::Vector3d& up, double cos_max_tilt,
                     int iterations, double band_share) {
  const std::vector<Eigen::Vector3d>& pts = *pp.points;
  Plane best;
  size_t best_region = 0;
  Lcg rng;
  for (int it = 0; it < iterations; ++it) {
    const Eigen::Vector3d& a = pts[rng.Next(pts.size())];
    const Eigen::Vector3d& b = pts[rng.Next(pts.size())];
    const Eigen::Vector3d& c = pts[rng.Next(pts.size())];
    Eigen::Vector3d n = (b - a).cross(c - a);
    if (n.norm() < 1e-9) continue;
    n.normalize();
    if (n.dot(up) < 0) n = -n;
    if (n.dot(up) < cos_max_tilt) continue;
    Plane plane{n, n.dot(a), 0};
    const std::vector<char> on = OnPlaneCells(pp, band_share, &plane);
    if (static_cast<size_t>(std::count(on.begin(), on.end(), 1)) <= best_region) {
      continue;  // no region of it can be larger
    }
    size_t region = 0;
    for (const auto& r : Regions(CellKeys(pp, on))) region = std::max(region, r.size());
    if (region > best_region) {
      best = plane;
      best_region = region;
    }
  }
  return best;
}

}  // namespace

SupportTops::SupportTops(const std::vector<Eigen::Vector3d>& points_kf, const Eigen::Vector3d& up_kf,
                         const SupportTopsOptions& options, const detection::MaskOptions& mask)
    : options_(options), margin_m_(mask.flat_top_margin_m), up_(up_kf.normalized()) {
  e1_ = up_.unitOrthogonal();
  e2_ = up_.cross(e1_);
  if (!options_.enabled || points_kf.size() < 3) return;
  const double cos_max_tilt = std::cos(options_.max_tilt_deg * M_PI / 180.0);
  std::vector<Eigen::Vector3d> rest = points_kf;
  for (int k = 0; k < options_.max_planes && rest.size() >= 3; ++k) {
    const PlanePoints pp =
        Prepare(rest, mask, [this](const Eigen::Vector3d& p) { return CellOf(p); });
    Plane plane = BestLevelPlane(pp, up_, cos_max_tilt, options_.ransac_iterations,
                                 options_.cell_band_share);
    if (plane.inliers < 3) break;
    // The plane's points: within its tolerance and in its cells; the others stay for the next.
    const std::vector<char> on = OnPlaneCells(pp, options_.cell_band_share, &plane);
    std::vector<Eigen::Vector3d> inliers, outliers;
    for (size_t i = 0; i < rest.size(); ++i) {
      const bool near = std::abs(plane.normal.dot(rest[i]) - plane.offset_m) <= pp.tolerance_m[i];
      (near && on[pp.cell_of[i]] ? inliers : outliers).push_back(rest[i]);
    }
    if (inliers.size() < 3) break;
    AddPlaneTops(inliers, plane.normal, plane.offset_m);
    rest.swap(outliers);
  }
  DropShelves();
}

int64_t SupportTops::CellOf(const Eigen::Vector3d& p) const {
  return PackCell(static_cast<int64_t>(std::floor(e1_.dot(p) / options_.cell_m)),
                  static_cast<int64_t>(std::floor(e2_.dot(p) / options_.cell_m)));
}

void SupportTops::AddPlaneTops(const std::vector<Eigen::Vector3d>& inliers,
                               const Eigen::Vector3d& normal, double offset_m) {
  std::unordered_set<int64_t> cells;
  double height_sum = 0;
  for (const Eigen::Vector3d& p : inliers) {
    cells.insert(CellOf(p));
    height_sum += up_.dot(p);
  }
  const double height_m = height_sum / static_cast<double>(std::max<size_t>(1, inliers.size()));
  const double min_cells = options_.min_top_area_m2 / (options_.cell_m * options_.cell_m);
  for (auto& region : Regions(std::move(cells))) {
    if (static_cast<double>(region.size()) < min_cells) continue;
    tops_.push_back({normal, offset_m, height_m, std::move(region)});
  }
}

void SupportTops::DropShelves() {
  std::sort(tops_.begin(), tops_.end(),
            [](const Top& a, const Top& b) { return a.height_m > b.height_m; });
  std::vector<Top> kept;
  for (Top& top : tops_) {
    size_t under = 0;
    for (const Top& higher : kept) {
      for (int64_t c : top.cells) under += higher.cells.count(c);
    }
    if (2 * under < top.cells.size()) kept.push_back(std::move(top));
  }
  tops_.swap(kept);
}

int SupportTops::TopOf(const Eigen::Vector3d& p_kf) const {
  if (tops_.empty()) return -1;
  int64_t i = 0, j = 0;
  UnpackCell(CellOf(p_kf), &i, &j);
  const int64_t reach = static_cast<int64_t>(std::ceil(options_.reach_m / options_.cell_m));
  // Rings of growing Chebyshev distance: the first ring that meets a footprint decides.
  for (int64_t r = 0; r <= reach; ++r) {
    for (size_t t = 0; t < tops_.size(); ++t) {
      const Top& top = tops_[t];
      if (top.normal.dot(p_kf) - top.offset_m > margin_m_) continue;  // stands on it
      for (int64_t di = -r; di <= r; ++di) {
        for (int64_t dj = -r; dj <= r; ++dj) {
          if (std::max(std::llabs(di), std::llabs(dj)) != r) continue;
          if (top.cells.count(PackCell(i + di, j + dj))) return static_cast<int>(t);
        }
      }
    }
  }
  return -1;
}

}  // namespace loci::server
