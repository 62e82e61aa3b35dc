// Oriented footprints: convex hulls and the overlap of convex polygons.
#include "query/footprint.h"

#include <cmath>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

namespace loci::query {
namespace {

Footprint Square(double x0, double y0, double side, double turn_rad = 0) {
  const Eigen::Vector2d c(x0 + side / 2, y0 + side / 2);
  const Eigen::Rotation2Dd R(turn_rad);
  std::vector<Eigen::Vector2d> corners;
  for (const auto& [u, v] : {std::pair{-1, -1}, {1, -1}, {1, 1}, {-1, 1}}) {
    corners.push_back(c + R * Eigen::Vector2d(u * side / 2, v * side / 2));
  }
  return ConvexHull(corners);
}

TEST(Footprint, HullOfABoxsProjectedCornersIsItsOutline) {
  // A box's 8 corners projected: every footprint corner twice, plus points inside.
  std::vector<Eigen::Vector2d> pts = {{0, 0}, {2, 0}, {2, 1}, {0, 1}, {0, 0}, {2, 0},
                                      {2, 1}, {0, 1}, {1, 0.5}, {0.5, 0.2}};
  const Footprint hull = ConvexHull(pts);
  ASSERT_EQ(hull.size(), 4u);
  EXPECT_NEAR(PolygonArea(hull), 2.0, 1e-12);
  EXPECT_LT(ConvexHull({{0, 0}, {1, 1}, {2, 2}}).size(), 3u);  // collinear: no area
  EXPECT_DOUBLE_EQ(PolygonArea(ConvexHull({{0, 0}, {1, 1}, {2, 2}})), 0.0);
}

TEST(Footprint, OverlapOfConvexPolygons) {
  EXPECT_NEAR(ConvexOverlapArea(Square(0, 0, 1), Square(0.5, 0, 1)), 0.5, 1e-12);
  EXPECT_NEAR(ConvexOverlapArea(Square(0, 0, 1), Square(0.25, 0.25, 0.5)), 0.25, 1e-12);
  EXPECT_DOUBLE_EQ(ConvexOverlapArea(Square(0, 0, 1), Square(2, 0, 1)), 0.0);
  // A unit square turned 45 deg about the centre of another: the octagon they share.
  const double octagon = 2 * (std::sqrt(2.0) - 1);
  EXPECT_NEAR(ConvexOverlapArea(Square(0, 0, 1), Square(0, 0, 1, M_PI / 4)), octagon, 1e-9);
  EXPECT_NEAR(ConvexOverlapArea(Square(0, 0, 1, M_PI / 4), Square(0, 0, 1)), octagon, 1e-9);
}

}  // namespace
}  // namespace loci::query
