// Synthetic office maps with known relations, for the query benchmark and scale tests: rooms on
// a grid, each with a dining table (book, cup, laptop, bottle on it; chairs around, one tucked
// under), a desk (tv, keyboard, mouse on it; a chair under it), a shelf with books on top, a
// couch and a potted plant. The result is a ground-truth scene (objects.json layout, z up, `on_id`
// set), so the same tests run on `loci synth` scenes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "common/map_object.h"
#include "common/objects_json.h"

namespace loci::query {

struct SyntheticMapOptions {
  size_t object_count = 10000;  // objects to generate (whole rooms are cut at this count)
  uint64_t seed = 1;            // random seed of sizes and placements
  double room_m = 6.0;          // side of one room (m)
};

GroundTruthScene MakeSyntheticOffice(const SyntheticMapOptions& options);

// Map objects of a ground-truth scene as a perfect mapper would report them: class from the
// ground truth with confidence `confidence`, boxes as given (oriented box = the AABB), seen at
// `t_ns` by `robot`.
std::vector<MapObject> MapObjectsFromGroundTruth(const GroundTruthScene& scene, int64_t t_ns = 0,
                                                 const std::string& robot = "synth",
                                                 double confidence = 0.9);

}  // namespace loci::query
