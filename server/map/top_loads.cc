#include "server/map/top_loads.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

#include "common/footprint.h"
#include "server/map/fused_object.h"

namespace loci::server {
namespace {

bool IsTable(const MapObject& o, const std::vector<std::string>& flat_top_classes) {
  return o.confirmed && std::isfinite(o.top_surface_z_m) &&
         IsFlatTopClass(flat_top_classes, o.class_name);
}

// An unconfirmed piece of furniture with enough views to hold loads (TopLoadOptions).
bool IsRival(const MapObject& o, const std::vector<std::string>& flat_top_classes,
             const TopLoadOptions& options) {
  return !o.confirmed && options.rival_min_views > 0 && std::isfinite(o.top_surface_z_m) &&
         o.observation_count >= static_cast<uint32_t>(options.rival_min_views) &&
         IsFlatTopClass(flat_top_classes, o.class_name);
}

// Gap between two intervals (0 when they overlap) and the overlap's length.
double IntervalGap(double a0, double a1, double b0, double b1) {
  return std::max({0.0, b0 - a1, a0 - b1});
}
double IntervalOverlap(double a0, double a1, double b0, double b1) {
  return std::max(0.0, std::min(a1, b1) - std::max(a0, b0));
}

// A box holding the object's axis-aligned box and its oriented box (map frame).
void EnclosingBox(const MapObject& o, Eigen::Vector3d* lo, Eigen::Vector3d* hi) {
  *lo = o.aabb_min_m;
  *hi = o.aabb_max_m;
  const Eigen::Vector3d h = o.R_map_box.cwiseAbs() * o.obb_half_extent_m.cwiseAbs();
  if (!h.allFinite() || !o.obb_center_m.allFinite()) return;
  *lo = lo->cwiseMin(o.obb_center_m - h);
  *hi = hi->cwiseMax(o.obb_center_m + h);
}

// The load's footprint corners at the table top's height (map frame).
std::vector<Eigen::Vector3d> FootprintCorners(const MapObject& load, double z_m) {
  const Eigen::Vector3d& lo = load.aabb_min_m;
  const Eigen::Vector3d& hi = load.aabb_max_m;
  return {
      {lo.x(), lo.y(), z_m}, {hi.x(), lo.y(), z_m}, {lo.x(), hi.y(), z_m}, {hi.x(), hi.y(), z_m}};
}

// Grows the table's boxes to hold the loads' footprints; the centroid follows the box centre.
void Widen(const std::vector<const MapObject*>& loads, MapObject* table) {
  const Eigen::Vector3d old_centre = 0.5 * (table->aabb_min_m + table->aabb_max_m);
  const Eigen::Matrix3d& R = table->R_map_box;
  Eigen::Vector3d lo = -table->obb_half_extent_m, hi = table->obb_half_extent_m;
  for (const MapObject* load : loads) {
    for (const Eigen::Vector3d& c : FootprintCorners(*load, table->top_surface_z_m)) {
      table->aabb_min_m.head<2>() = table->aabb_min_m.head<2>().cwiseMin(c.head<2>());
      table->aabb_max_m.head<2>() = table->aabb_max_m.head<2>().cwiseMax(c.head<2>());
      const Eigen::Vector3d q = R.transpose() * (c - table->obb_center_m);
      lo = lo.cwiseMin(q);
      hi = hi.cwiseMax(q);
    }
  }
  table->obb_center_m += R * (0.5 * (lo + hi));
  table->obb_half_extent_m = 0.5 * (hi - lo);
  const Eigen::Vector3d new_centre = 0.5 * (table->aabb_min_m + table->aabb_max_m);
  table->centroid_m.head<2>() += (new_centre - old_centre).head<2>();
}

// The table among `tables` that `load` rests on best (TopLoadOptions), or objects.size().
size_t BestTable(const MapObject& load, const std::vector<MapObject>& objects,
                 const std::vector<size_t>& tables, const TopLoadOptions& options) {
  size_t best = objects.size();
  double best_overlap = 0, best_distance = 0, best_gap = 0;
  for (size_t t : tables) {
    double distance = 0, overlap = 0;
    if (!RestsOn(load, objects[t], options, &distance, &overlap)) continue;
    const double gap = std::abs(load.aabb_min_m.z() - objects[t].top_surface_z_m);
    constexpr double kEps = 1e-9;
    const bool better =
        overlap > best_overlap + kEps ||
        (overlap > best_overlap - kEps &&
         (distance < best_distance - kEps || (distance < best_distance + kEps && gap < best_gap)));
    if (best == objects.size() || better) {
      best = t;
      best_overlap = overlap;
      best_distance = distance;
      best_gap = gap;
    }
  }
  return best;
}

bool IsLoad(const MapObject& o, const std::vector<std::string>& flat_top_classes,
            const TopLoadOptions& options) {
  const auto& floor = options.floor_classes;
  return o.confirmed && !IsFlatTopClass(flat_top_classes, o.class_name) &&
         std::find(floor.begin(), floor.end(), o.class_name) == floor.end();
}

// (load, table) indices into `objects` of the loads whose box bottom lies above the top of the
// confirmed table they rest on best.
std::vector<std::pair<size_t, size_t>> HoveringLoads(
    const std::vector<std::string>& flat_top_classes, const TopLoadOptions& options,
    const std::vector<MapObject>& objects) {
  std::vector<std::pair<size_t, size_t>> out;
  if (!options.lower_loads || options.reach_m <= 0) return out;
  std::vector<size_t> tables;
  for (size_t i = 0; i < objects.size(); ++i) {
    if (IsTable(objects[i], flat_top_classes)) tables.push_back(i);
  }
  if (tables.empty()) return out;
  for (size_t l = 0; l < objects.size(); ++l) {
    const MapObject& load = objects[l];
    if (!IsLoad(load, flat_top_classes, options)) continue;
    const size_t t = BestTable(load, objects, tables, options);
    if (t != objects.size() && load.aabb_min_m.z() > objects[t].top_surface_z_m) {
      out.emplace_back(l, t);
    }
  }
  return out;
}

// Extends the load's boxes down to top_z_m (LowerLoadsOntoTops).
void LowerOnto(double top_z_m, MapObject* load) {
  const double drop_m = load->aabb_min_m.z() - top_z_m;
  load->aabb_min_m.z() = top_z_m;
  load->centroid_m.z() -= 0.5 * drop_m;
  if (std::isfinite(load->bottom_z_m) && load->bottom_z_m > top_z_m) load->bottom_z_m = top_z_m;
  const Eigen::Matrix3d& R = load->R_map_box;
  Eigen::Index k = 0;
  R.row(2).cwiseAbs().maxCoeff(&k);
  const double up = R(2, k);
  constexpr double kCosMaxTilt = 0.9396926;  // cos(20 deg)
  if (!(std::abs(up) >= kCosMaxTilt) || !load->obb_center_m.allFinite()) return;
  const Eigen::Vector3d h = load->obb_half_extent_m.cwiseAbs();
  const double obb_drop_m = load->obb_center_m.z() - R.row(2).cwiseAbs().dot(h) - top_z_m;
  if (!(obb_drop_m > 0)) return;
  const double along_m = obb_drop_m / std::abs(up);  // along axis k, which points up or down
  load->obb_half_extent_m(k) = h(k) + 0.5 * along_m;
  load->obb_center_m -= (up > 0 ? 1.0 : -1.0) * (0.5 * along_m) * R.col(k);
}

}  // namespace

void LowerLoadsOntoTops(const std::vector<std::string>& flat_top_classes,
                        const TopLoadOptions& options, std::vector<MapObject>* objects) {
  for (const auto& [l, t] : HoveringLoads(flat_top_classes, options, *objects)) {
    LowerOnto((*objects)[t].top_surface_z_m, &(*objects)[l]);
  }
}

std::vector<int64_t> LoadsLoweredOnto(const std::vector<int64_t>& table_ids,
                                      const std::vector<std::string>& flat_top_classes,
                                      const TopLoadOptions& options,
                                      const std::vector<MapObject>& objects) {
  std::vector<int64_t> ids;
  for (const auto& [l, t] : HoveringLoads(flat_top_classes, options, objects)) {
    if (std::find(table_ids.begin(), table_ids.end(), objects[t].id) != table_ids.end()) {
      ids.push_back(objects[l].id);
    }
  }
  return ids;
}

double FootprintDistanceM(const Eigen::Vector3d& a_min, const Eigen::Vector3d& a_max,
                          const Eigen::Vector3d& b_min, const Eigen::Vector3d& b_max) {
  return std::hypot(IntervalGap(a_min.x(), a_max.x(), b_min.x(), b_max.x()),
                    IntervalGap(a_min.y(), a_max.y(), b_min.y(), b_max.y()));
}

bool RestsOn(const MapObject& load, const MapObject& table, const TopLoadOptions& options,
             double* distance_m, double* overlap) {
  const Eigen::Vector3d &a0 = load.aabb_min_m, &a1 = load.aabb_max_m;
  const Eigen::Vector3d &b0 = table.aabb_min_m, &b1 = table.aabb_max_m;
  const auto stand = options.stand_m.find(load.class_name);
  const double stand_m = stand == options.stand_m.end() ? 0.0 : stand->second;
  const double above_m = a0.z() - table.top_surface_z_m;
  if (!(above_m <= options.max_gap_m + stand_m && -above_m <= options.max_sink_m &&
        a1.z() > table.top_surface_z_m)) {
    return false;
  }
  // Boxes holding both the axis-aligned box and the outline: apart by more than the reach, so
  // are the outlines (most pairs; no outline made).
  Eigen::Vector3d load_lo, load_hi, table_lo, table_hi;
  EnclosingBox(load, &load_lo, &load_hi);
  EnclosingBox(table, &table_lo, &table_hi);
  if (FootprintDistanceM(load_lo, load_hi, table_lo, table_hi) > options.reach_m) return false;
  const Footprint load_fp = OrientedFootprint(load), table_fp = OrientedFootprint(table);
  const double load_area = PolygonArea(load_fp);
  const bool oriented = load_area > 1e-9 && PolygonArea(table_fp) > 1e-9;
  const double shared = oriented ? ConvexOverlapArea(load_fp, table_fp) : 0.0;
  const double distance = oriented ? (shared > 0 ? 0.0 : ConvexDistanceM(load_fp, table_fp))
                                   : FootprintDistanceM(a0, a1, b0, b1);
  if (distance > options.reach_m) return false;
  if (distance_m != nullptr) *distance_m = distance;
  if (overlap != nullptr) {
    const double area = std::max(1e-9, (a1.x() - a0.x()) * (a1.y() - a0.y()));
    *overlap = oriented ? shared / load_area
                        : IntervalOverlap(a0.x(), a1.x(), b0.x(), b1.x()) *
                              IntervalOverlap(a0.y(), a1.y(), b0.y(), b1.y()) / area;
  }
  return true;
}

void ExtendTopsUnderLoads(const std::vector<std::string>& flat_top_classes,
                          const TopLoadOptions& options, std::vector<MapObject>* objects) {
  if (options.reach_m <= 0) return;
  std::vector<size_t> tables, loads;
  std::vector<char> rival(objects->size(), 0);
  for (size_t i = 0; i < objects->size(); ++i) {
    const MapObject& o = (*objects)[i];
    if (IsTable(o, flat_top_classes)) {
      tables.push_back(i);
    } else if (IsRival(o, flat_top_classes, options)) {
      tables.push_back(i);
      rival[i] = 1;
    } else if (o.confirmed && !IsFlatTopClass(flat_top_classes, o.class_name)) {
      loads.push_back(i);
    }
  }
  if (tables.empty()) return;
  // Rounds: a top grown under the keyboard reaches the mouse beside it. Each load joins one
  // table, chosen against the footprints of its round, so the result does not depend on order.
  while (!loads.empty()) {
    std::map<size_t, std::vector<const MapObject*>> on_table;
    std::vector<size_t> left;
    for (size_t l : loads) {
      const size_t t = BestTable((*objects)[l], *objects, tables, options);
      if (t == objects->size()) {
        left.push_back(l);
      } else if (!rival[t]) {
        on_table[t].push_back(&(*objects)[l]);
      }
    }
    if (on_table.empty()) break;
    for (const auto& [t, on_top] : on_table) Widen(on_top, &(*objects)[t]);
    loads.swap(left);
  }
}

int LoadsHeldBy(int64_t table_id, const std::vector<std::string>& flat_top_classes,
                const TopLoadOptions& options, const std::vector<MapObject>& objects) {
  if (options.reach_m <= 0) return 0;
  std::vector<size_t> tables;
  size_t held_by = objects.size();
  for (size_t i = 0; i < objects.size(); ++i) {
    const MapObject& o = objects[i];
    if (!IsTable(o, flat_top_classes) && !IsRival(o, flat_top_classes, options)) continue;
    tables.push_back(i);
    if (o.id == table_id) held_by = i;
  }
  if (held_by == objects.size()) return 0;
  int held = 0;
  for (const MapObject& load : objects) {
    const auto& floor = options.floor_classes;
    if (!load.confirmed || IsFlatTopClass(flat_top_classes, load.class_name) ||
        std::find(floor.begin(), floor.end(), load.class_name) != floor.end()) {
      continue;
    }
    held += BestTable(load, objects, tables, options) == held_by;
  }
  return held;
}

std::vector<int64_t> TablesUnderLoads(const std::vector<std::string>& flat_top_classes,
                                      const TopLoadOptions& options,
                                      const std::vector<MapObject>& loads,
                                      const std::vector<MapObject>& objects) {
  std::vector<int64_t> ids;
  if (options.reach_m <= 0) return ids;
  for (const MapObject& table : objects) {
    if (!IsTable(table, flat_top_classes)) continue;
    for (const MapObject& load : loads) {
      if (IsFlatTopClass(flat_top_classes, load.class_name) ||
          !RestsOn(load, table, options, nullptr, nullptr)) {
        continue;
      }
      ids.push_back(table.id);
      break;
    }
  }
  return ids;
}

}  // namespace loci::server
