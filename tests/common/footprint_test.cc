// Oriented footprints: convex hulls and the overlap of convex polygons.
#include "common/footprint.h"

#include <cmath>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

namespace loci {
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

TEST(Footprint, DistanceBetweenConvexPolygons) {
  EXPECT_NEAR(ConvexDistanceM(Square(0, 0, 1), Square(1.5, 0, 1)), 0.5, 1e-12);
  EXPECT_NEAR(ConvexDistanceM(Square(0, 0, 1), Square(2, 2, 1)), std::sqrt(2.0), 1e-12);
  EXPECT_DOUBLE_EQ(ConvexDistanceM(Square(0, 0, 1), Square(0.5, 0.5, 1)), 0.0);
  // A unit square turned 45 deg, its corner pointing at the other's side 0.2 m away.
  const double half_diagonal = std::sqrt(0.5);
  const Footprint diamond = Square(1.2 + half_diagonal - 0.5, 0, 1, M_PI / 4);
  EXPECT_NEAR(ConvexDistanceM(Square(0, 0, 1), diamond), 0.2, 1e-9);
  EXPECT_NEAR(ConvexDistanceM(diamond, Square(0, 0, 1)), 0.2, 1e-9);
  EXPECT_TRUE(std::isinf(ConvexDistanceM({}, Square(0, 0, 1))));
}

TEST(Footprint, AnObjectsOrientedBoxOutlinesItsFootprint) {
  MapObject o;
  o.obb_center_m = {1.0, 2.0, 0.8};
  o.obb_half_extent_m = {0.3, 0.1, 0.05};
  o.R_map_box = Eigen::AngleAxisd(M_PI / 4, Eigen::Vector3d::UnitZ()).matrix();
  const Footprint fp = OrientedFootprint(o);
  ASSERT_EQ(fp.size(), 4u);
  EXPECT_NEAR(PolygonArea(fp), 0.6 * 0.2, 1e-12);  // its axis-aligned box's: 0.32
  for (const Eigen::Vector2d& c : fp) EXPECT_NEAR((c - Eigen::Vector2d(1, 2)).norm(),
                                                  std::hypot(0.3, 0.1), 1e-12);
  o.obb_half_extent_m.setZero();
  EXPECT_TRUE(OrientedFootprint(o).empty());
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
}  // namespace loci
