// MapObject in another frame, and its bottom height.
#include "common/map_object.h"

#include <cmath>

#include <gtest/gtest.h>

namespace loci {
namespace {

MapObject Book() {
  MapObject o;
  o.aabb_min_m = {0.2, 0.2, 0.70};
  o.aabb_max_m = {0.45, 0.4, 0.82};
  o.centroid_m = {0.325, 0.3, 0.795};
  o.top_surface_z_m = 0.815;
  o.bottom_z_m = 0.77;
  return o;
}

TEST(MapObject, HeightsMoveWithATransformThatKeepsUpAndAreDroppedByATilt) {
  const SE3d T_b_a = SE3FromTum(1.0, -2.0, 0.5, 0, 0, std::sin(0.3), std::cos(0.3));  // yaw
  const MapObject moved = Transformed(Book(), T_b_a);
  EXPECT_NEAR(moved.bottom_z_m, 1.27, 1e-12);
  EXPECT_NEAR(moved.top_surface_z_m, 1.315, 1e-12);
  EXPECT_NEAR(moved.aabb_min_m.z(), 1.20, 1e-12);
  EXPECT_NEAR(BottomZ(moved), 1.27, 1e-12);
  const SE3d tilt = SE3FromTum(0, 0, 0, std::sin(0.05), 0, 0, std::cos(0.05));
  const MapObject tilted = Transformed(Book(), tilt);
  EXPECT_TRUE(std::isnan(tilted.bottom_z_m));
  EXPECT_TRUE(std::isnan(tilted.top_surface_z_m));
  EXPECT_DOUBLE_EQ(BottomZ(tilted), tilted.aabb_min_m.z());
}

TEST(MapObject, BottomZIsTheBoxBottomWhenUnknownOrOutsideTheBox) {
  MapObject o = Book();
  EXPECT_DOUBLE_EQ(BottomZ(o), 0.77);
  o.bottom_z_m = std::nan("");
  EXPECT_DOUBLE_EQ(BottomZ(o), 0.70);
  o.bottom_z_m = 0.9;  // above the box: not this object's
  EXPECT_DOUBLE_EQ(BottomZ(o), 0.70);
}

}  // namespace
}  // namespace loci
