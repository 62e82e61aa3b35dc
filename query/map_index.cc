#include "query/map_index.h"

#include <algorithm>
#include <cmath>

namespace loci::query {
namespace {

// Objects spanning more grid cells than this are kept in a list checked by every query.
constexpr int64_t kMaxCellsPerObject = 256;
// Most cells of the dense grid; larger maps get larger cells.
constexpr double kMaxGridCells = 4e6;

bool Finite(const MapObject& o) {
  return o.centroid_m.allFinite() && o.aabb_min_m.allFinite() && o.aabb_max_m.allFinite() &&
         o.obb_center_m.allFinite() && o.obb_half_extent_m.allFinite() && o.R_map_box.allFinite();
}

}  // namespace

std::string_view UpSourceName(UpSource source) {
  switch (source) {
    case UpSource::kGiven:
      return "given";
    case UpSource::kViewpoints:
      return "viewpoints";
    default:
      return "config";
  }
}

Status ValidateFilter(const ObjectFilter& f) {
  if (!(f.min_confidence >= 0 && f.min_confidence <= 1)) {
    return absl::InvalidArgumentError("min_confidence must be in [0, 1]");
  }
  if (f.box_min_m.has_value() != f.box_max_m.has_value()) {
    return absl::InvalidArgumentError("a box filter needs both box_min_m and box_max_m");
  }
  if (f.box_min_m && (!f.box_min_m->allFinite() || !f.box_max_m->allFinite() ||
                      (f.box_min_m->array() > f.box_max_m->array()).any())) {
    return absl::InvalidArgumentError("box filter: need finite corners with min <= max");
  }
  if (!(f.radius_m >= 0) || !std::isfinite(f.radius_m)) {
    return absl::InvalidArgumentError("radius_m must be finite and >= 0");
  }
  if (f.radius_m > 0 && (!f.near_center_m || !f.near_center_m->allFinite())) {
    return absl::InvalidArgumentError("radius_m > 0 needs a finite near_center_m");
  }
  return absl::OkStatus();
}

std::shared_ptr<const MapIndex> MapIndex::Build(std::vector<MapObject> objects,
                                                std::optional<Vec3d> up_map,
                                                std::vector<Viewpoint> viewpoints,
                                                const QueryOptions& options,
                                                const Vocabulary& vocabulary,
                                                std::vector<MapObject> removed) {
  UpSource source = UpSource::kConfig;
  Vec3d up = options.default_up_map;
  if (up_map && up_map->allFinite() && up_map->norm() > 1e-6) {
    up = *up_map;
    source = UpSource::kGiven;
  } else if (options.up_from_viewpoints) {
    if (auto est = EstimateUpFromViewpoints(viewpoints)) {
      up = *est;
      source = UpSource::kViewpoints;
    }
  }
  std::shared_ptr<MapIndex> index(new MapIndex(GravityFrame(up), vocabulary));
  index->up_source_ = source;
  index->cell_m_ = options.grid_cell_m;

  // Objects with non-finite geometry cannot take part in relations: drop them.
  objects.erase(
      std::remove_if(objects.begin(), objects.end(), [](const MapObject& o) { return !Finite(o); }),
      objects.end());
  index->objects_ = std::move(objects);
  index->removed_ = std::move(removed);
  const size_t n = index->objects_.size();
  index->geoms_.reserve(n);
  index->eligible_.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const MapObject& o = index->objects_[i];
    index->geoms_.push_back(index->gravity_.Geom(o));
    index->index_of_id_[o.id] = static_cast<int>(i);
    index->by_class_[o.class_name].push_back(static_cast<int>(i));
    index->vocabulary_.AddClass(o.class_name);
    const bool ok =
        o.confidence >= options.min_object_confidence && (!options.confirmed_only || o.confirmed);
    index->eligible_[i] = ok;
    if (ok) ++index->class_counts_[o.class_name];

    const BoxG& b = index->geoms_.back().box;
    if (i == 0) index->bounds_ = b;
    index->bounds_.min = index->bounds_.min.cwiseMin(b.min);
    index->bounds_.max = index->bounds_.max.cwiseMax(b.max);
  }
  index->BuildGrid();
  // Most recent first (stable for equal stamps).
  std::vector<size_t> idx(viewpoints.size());
  for (size_t i = 0; i < idx.size(); ++i) idx[i] = i;
  std::stable_sort(idx.begin(), idx.end(),
                   [&](size_t a, size_t b) { return viewpoints[a].t_ns > viewpoints[b].t_ns; });
  for (size_t i : idx) {
    if (auto g = index->gravity_.View(viewpoints[i])) index->viewpoints_.push_back(*g);
  }
  return index;
}

std::optional<int> MapIndex::IndexOfId(int64_t id) const {
  auto it = index_of_id_.find(id);
  if (it == index_of_id_.end()) return std::nullopt;
  return it->second;
}

std::vector<int> MapIndex::OfClasses(const std::vector<std::string>& classes) const {
  std::vector<int> out;
  for (const std::string& c : classes) {
    auto it = by_class_.find(c);
    if (it != by_class_.end()) out.insert(out.end(), it->second.begin(), it->second.end());
  }
  if (classes.size() > 1) {
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
  }
  return out;
}

MapIndex::CellRange MapIndex::Cells(const BoxG& box, double radius_m) const {
  auto cell = [&](double v, double origin, int64_t n) {
    return std::clamp<int64_t>(static_cast<int64_t>(std::floor((v - origin) / cell_m_)), -1, n);
  };
  return {cell(box.min.x() - radius_m, bounds_.min.x(), nx_),
          cell(box.max.x() + radius_m, bounds_.min.x(), nx_),
          cell(box.min.y() - radius_m, bounds_.min.y(), ny_),
          cell(box.max.y() + radius_m, bounds_.min.y(), ny_)};
}

void MapIndex::BuildGrid() {
  const Vec3d span = bounds_.max - bounds_.min;
  const double area = std::max(span.x(), cell_m_) * std::max(span.y(), cell_m_);
  cell_m_ = std::max(cell_m_, std::sqrt(area / kMaxGridCells));
  nx_ = static_cast<int64_t>(std::floor(span.x() / cell_m_)) + 1;
  ny_ = static_cast<int64_t>(std::floor(span.y() / cell_m_)) + 1;
  // Compressed rows: cell c holds cell_items_[cell_start_[c] .. cell_start_[c + 1]).
  std::vector<int> count(nx_ * ny_ + 1, 0);
  std::vector<char> large(geoms_.size(), 0);
  for (size_t i = 0; i < geoms_.size(); ++i) {
    const CellRange r = Cells(geoms_[i].box, 0.0);
    if ((r.x1 - r.x0 + 1) * (r.y1 - r.y0 + 1) > kMaxCellsPerObject) {
      large[i] = 1;
      large_.push_back(static_cast<int>(i));
      continue;
    }
    for (int64_t ix = r.x0; ix <= r.x1; ++ix) {
      for (int64_t iy = r.y0; iy <= r.y1; ++iy) ++count[ix * ny_ + iy + 1];
    }
  }
  for (size_t c = 1; c < count.size(); ++c) count[c] += count[c - 1];
  cell_start_ = count;
  cell_items_.resize(count.back());
  for (size_t i = 0; i < geoms_.size(); ++i) {
    if (large[i]) continue;
    const CellRange r = Cells(geoms_[i].box, 0.0);
    for (int64_t ix = r.x0; ix <= r.x1; ++ix) {
      for (int64_t iy = r.y0; iy <= r.y1; ++iy) {
        cell_items_[count[ix * ny_ + iy]++] = static_cast<int>(i);
      }
    }
  }
}

std::vector<int> MapIndex::Candidates(const BoxG& box, double radius_m) const {
  std::vector<int> out;
  if (geoms_.empty()) return out;
  out.reserve(64);
  // Objects spanning several cells are met several times: a per-thread stamp per object
  // (generation counter) drops the repeats without sorting.
  thread_local std::vector<uint32_t> stamp;
  thread_local uint32_t generation = 0;
  if (stamp.size() < geoms_.size()) stamp.resize(geoms_.size(), 0);
  if (++generation == 0) {
    std::fill(stamp.begin(), stamp.end(), 0);
    generation = 1;
  }
  auto take = [&](int i) {
    if (stamp[i] == generation) return;
    stamp[i] = generation;
    if (HorizontalGap(geoms_[i].box, box) <= radius_m) out.push_back(i);
  };
  const CellRange r = Cells(box, radius_m);
  for (int64_t ix = std::max<int64_t>(r.x0, 0); ix <= std::min(r.x1, nx_ - 1); ++ix) {
    const int64_t y0 = std::max<int64_t>(r.y0, 0);
    const int64_t y1 = std::min(r.y1, ny_ - 1);
    if (y0 > y1) break;
    // Cells of one column are contiguous in cell_items_.
    const int begin = cell_start_[ix * ny_ + y0];
    const int end = cell_start_[ix * ny_ + y1 + 1];
    for (int k = begin; k < end; ++k) take(cell_items_[k]);
  }
  for (int i : large_) take(i);
  return out;
}

std::vector<int> MapIndex::Find(const ObjectFilter& f) const {
  std::vector<int> pool;
  if (f.classes.empty()) {
    pool.resize(objects_.size());
    for (size_t i = 0; i < pool.size(); ++i) pool[i] = static_cast<int>(i);
  } else {
    pool = OfClasses(f.classes);
  }
  std::vector<int> out;
  for (int i : pool) {
    const MapObject& o = objects_[i];
    if (o.confidence < f.min_confidence || (f.confirmed_only && !o.confirmed)) continue;
    if (f.box_min_m && ((o.centroid_m.array() < f.box_min_m->array()).any() ||
                        (o.centroid_m.array() > f.box_max_m->array()).any())) {
      continue;
    }
    if (f.radius_m > 0 && (o.centroid_m - *f.near_center_m).norm() > f.radius_m) continue;
    out.push_back(i);
  }
  std::sort(out.begin(), out.end(), [&](int a, int b) { return objects_[a].id < objects_[b].id; });
  if (f.limit > 0 && out.size() > f.limit) out.resize(f.limit);
  return out;
}

}  // namespace loci::query
