// Pieces of answer sentences: object references, positions, "last seen" phrases and lists.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/map_object.h"
#include "query/vocabulary.h"

namespace loci::query {

// "the book (#12)"
std::string ObjectRef(const MapObject& object);
// "(1.20, 0.40, 0.76) m": the centroid in the map frame.
std::string Position(const MapObject& object);
// "last seen 12 s ago by robot-a"; without `now_ns` (0) "last seen by robot-a"; "" when nothing
// is known.
std::string SeenPhrase(const MapObject& object, int64_t now_ns);
// "12 s" / "3 min" / "2.5 h" for a duration in ns (negative -> "0 s").
std::string Duration(int64_t dt_ns);
// "a book", "an apple", "3 books", "no books".
std::string CountedClass(const Vocabulary& vocabulary, const std::string& class_name, int64_t n);
// "a", "b and c", "a, b and c"; at most `max_items` items, then "and N more".
std::string JoinItems(const std::vector<std::string>& items, size_t max_items);
// Capitalises the first letter.
std::string Capitalize(std::string s);
// Lower-cases the first letter.
std::string Uncapitalize(std::string s);

}  // namespace loci::query
