// Mapper input for tests: exactly rendered keyframes of a box world (box_world.h) on an arc
// around the boxes, with gravity, and map options for its classes.
#pragma once

#include <vector>

#include "server/map/mapper.h"
#include "tests/server/box_world.h"

namespace loci::server::testing {

// n keyframes (ids 1..n, robot1, 1 s apart) looking at the boxes from an arc of 70 degrees.
std::vector<MapperKeyframe> Views(const std::vector<WorldBox>& boxes, int n, bool masks);

// Map options for DefaultBoxes: book, cup, laptop mapped; person dynamic.
MapOptions BoxWorldOptions();

}  // namespace loci::server::testing
