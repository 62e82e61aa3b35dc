// A keyframe's products moved into the map frame: the points the mapper adds to objects and
// to the cloud. Computed the same way on integration and when the keyframe moves, so a move
// takes out exactly what was added.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "server/map/fused_object.h"
#include "server/map/keyframe_products.h"
#include "server/map/semantic_cloud.h"

namespace loci::server {

// An observation's points in the map frame.
std::vector<ColoredPoint> ObservationPointsMap(const ObjectObservation& observation,
                                               const Eigen::Isometry3f& T_map_kf);

// The static cloud in the map frame; a point of observation i carries object_ids[i].
std::vector<SemanticPoint> StaticPointsMap(const KeyframeProducts& products,
                                           const Eigen::Isometry3f& T_map_kf,
                                           const std::vector<int64_t>& object_ids);

}  // namespace loci::server
