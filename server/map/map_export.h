// File exports of the map: binary PLY clouds, objects JSON (a superset of objects.json, so
// ReadObjectsJson and `loci eval` read it) and the OctoMap .bt.
#pragma once

#include <string>
#include <vector>

#include "common/map_object.h"
#include "common/se3.h"
#include "common/status.h"
#include "server/map/semantic_cloud.h"

namespace loci::server {

// Binary little-endian PLY: x y z (float, m), red green blue (uchar), object_id (int).
Status WritePly(const std::string& path, const std::vector<SemanticPoint>& points);
// {"frame": "map", "up": [..], "objects": [{"id", "class_name", "confidence", "labels",
//  "centroid_m", "extent_m", "aabb_min_m", "aabb_max_m", "obb": {...}, "first_seen_ns", ...,
//  "observation_count", "missed_views", "existence", "confirmed", ...}]}: with --all, what holds
//  a candidate back (too few views, or too many views that missed it) can be read.
Status WriteObjectsJsonExport(const std::string& path, const std::vector<MapObject>& objects,
                              const Vec3d& up);

}  // namespace loci::server
