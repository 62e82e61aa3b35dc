// Shapes of the object classes a synthetic scene can hold, with class-typical sizes (metres)
// and where each class may stand. Parts are built in the object frame: origin at the centre of
// the footprint, lowest point at z = 0, z up, the front (screens, chair seat) facing -y.
#pragma once

#include <string>
#include <vector>

#include "synth/rng.h"
#include "synth/scene.h"

namespace loci::synth {

// Where an object of a class may be placed (bit set).
enum SupportMask : int { kOnTable = 1, kOnShelf = 2, kOnFloor = 4 };

struct ClassSpec {
  std::string name;  // COCO-80 name
  int coco_id;       // index in coco80.names
  int supports;      // SupportMask bits
};

// The classes the generator places: first the core office classes (book, cup, keyboard, mouse,
// bottle, tv, laptop, chair, teddy bear), then the others.
const std::vector<ClassSpec>& CoreClasses();
const std::vector<ClassSpec>& ExtraClasses();

// COCO-80 index of a class name, -1 when it is not a COCO class.
int CocoClassId(const std::string& name);

// Parts of one instance of `class_name` with random size variation (about +-10%). The parts'
// texture indices are 0; the caller assigns them. Empty for an unknown class.
std::vector<Primitive> BuildClassParts(const std::string& class_name, Rng& rng);

// Furniture and the person, sizes in metres (full sizes).
std::vector<Primitive> BuildTable(const Vec3d& size_m);
std::vector<Primitive> BuildShelf(const Vec3d& size_m);
std::vector<Primitive> BuildPerson(double height_m);

// World AABB of parts placed at T_world_obj (exact for boxes, cylinders and spheres).
void PartsAabb(const std::vector<Primitive>& parts, const SE3d& T_world_obj, Vec3d* min_m,
               Vec3d* max_m);

}  // namespace loci::synth
