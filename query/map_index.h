// An immutable, indexed snapshot of the map for queries: objects with their gravity-frame boxes,
// a class index and a horizontal grid over the footprints. Build once per map change and share
// between threads (every method is const and thread-safe).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "common/map_object.h"
#include "query/geometry.h"
#include "query/query_options.h"
#include "query/vocabulary.h"

namespace loci::query {

// Where the up direction of a snapshot came from.
enum class UpSource { kGiven, kViewpoints, kConfig };
std::string_view UpSourceName(UpSource source);

// Structured object search (FindObjects). Positions in the map frame, metres.
struct ObjectFilter {
  std::vector<std::string> classes;  // canonical class names; empty = any class
  double min_confidence = 0;         // [0, 1]
  bool confirmed_only = false;
  std::optional<Vec3d> box_min_m;  // axis-aligned box in the map frame: the centroid must lie in
  std::optional<Vec3d> box_max_m;  //   it (both corners needed)
  std::optional<Vec3d> near_center_m;  // sphere: centroid within radius_m of this point
  double radius_m = 0;                 // 0 = no sphere filter
  size_t limit = 0;                    // 0 = no limit
};
// InvalidArgument when the filter is inconsistent (negative radius, one box corner, ...).
Status ValidateFilter(const ObjectFilter& filter);

class MapIndex {
 public:
  // `up_map`: the map's up direction when the caller knows it (any length > 0). Otherwise the
  // viewpoints (when options.up_from_viewpoints) or options.default_up_map give it.
  // `vocabulary`: the engine's vocabulary; classes of the snapshot are added to the index's copy.
  static std::shared_ptr<const MapIndex> Build(std::vector<MapObject> objects,
                                               std::optional<Vec3d> up_map,
                                               std::vector<Viewpoint> viewpoints,
                                               const QueryOptions& options,
                                               const Vocabulary& vocabulary,
                                               std::vector<MapObject> removed = {});

  size_t size() const { return objects_.size(); }
  const MapObject& object(int i) const { return objects_[i]; }
  // Objects found gone (MapObject::removed_t_ns), for questions about changes; not indexed.
  const std::vector<MapObject>& removed() const { return removed_; }
  const ObjectGeom& geom(int i) const { return geoms_[i]; }
  // Passes the Ask-level filters of the options (min_object_confidence, confirmed_only).
  bool eligible(int i) const { return eligible_[i]; }
  std::optional<int> IndexOfId(int64_t id) const;

  // Indices of the objects of these classes (sorted, no duplicates).
  std::vector<int> OfClasses(const std::vector<std::string>& classes) const;
  // Object count per class (eligible objects only), sorted by class name.
  const std::map<std::string, int>& class_counts() const { return class_counts_; }
  // Indices of the objects whose footprint lies within `radius_m` of `box`'s footprint in g
  // (horizontal gap), no duplicates, in no particular order.
  std::vector<int> Candidates(const BoxG& box, double radius_m) const;
  // Bounding box of every object's box in g (zero box when empty).
  const BoxG& bounds() const { return bounds_; }
  // FindObjects: indices of matching objects, in id order.
  std::vector<int> Find(const ObjectFilter& filter) const;

  const GravityFrame& gravity() const { return gravity_; }
  UpSource up_source() const { return up_source_; }
  // Finite viewpoints in g, most recent first.
  const std::vector<ViewpointG>& viewpoints() const { return viewpoints_; }
  const Vocabulary& vocabulary() const { return vocabulary_; }

 private:
  MapIndex(const GravityFrame& gravity, const Vocabulary& vocabulary)
      : gravity_(gravity), vocabulary_(vocabulary) {}
  // Inclusive range of grid cells (clamped to [-1, n]) covering a box grown by radius_m.
  struct CellRange {
    int64_t x0, x1, y0, y1;
  };
  CellRange Cells(const BoxG& box, double radius_m) const;
  void BuildGrid();

  GravityFrame gravity_;
  UpSource up_source_ = UpSource::kConfig;
  Vocabulary vocabulary_;
  std::vector<MapObject> objects_;
  std::vector<MapObject> removed_;
  std::vector<ObjectGeom> geoms_;
  std::vector<bool> eligible_;
  std::unordered_map<int64_t, int> index_of_id_;
  std::unordered_map<std::string, std::vector<int>> by_class_;
  std::map<std::string, int> class_counts_;
  std::vector<ViewpointG> viewpoints_;
  BoxG bounds_;
  double cell_m_ = 1.0;
  // Dense grid over bounds_ (x_g, y_g), cell_m_ per side, nx_ * ny_ cells, column-major by x:
  // the objects of cell (ix, iy) are cell_items_[cell_start_[ix * ny_ + iy] ...
  // cell_start_[ix * ny_ + iy + 1]).
  int64_t nx_ = 0;
  int64_t ny_ = 0;
  std::vector<int> cell_start_;
  std::vector<int> cell_items_;
  std::vector<int> large_;  // objects covering too many cells, always candidates
};

}  // namespace loci::query
