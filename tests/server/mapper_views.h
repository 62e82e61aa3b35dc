// Mapper input for tests: exactly rendered keyframes of a box world (box_world.h) on an arc
// around the boxes, with gravity, and map options for its classes.
#pragma once

#include <vector>

#include "server/map/mapper.h"
#include "tests/server/box_world.h"

namespace loci::server::testing {

// n keyframes (ids first_id.., robot1, 1 s apart) looking at `target` from an arc of 70
// degrees, 1.4 m out and 0.9 m up.
std::vector<MapperKeyframe> Views(const std::vector<WorldBox>& boxes, int n, bool masks,
                                  const Eigen::Vector3d& target = {0.1, 0.05, 0.05},
                                  int64_t first_id = 1);

// Map options for DefaultBoxes: book, cup, laptop mapped; person dynamic.
MapOptions BoxWorldOptions();

}  // namespace loci::server::testing
