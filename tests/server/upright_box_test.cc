// Upright boxes (server/map/upright_box.h) on the shape fr1_rpy's main desk leaves in the map:
// the strip of its top the camera sees in front of the keyboard plus the front edge, turned
// 128 deg about up as the demo's map stands to the room (objects_gt.json, world frame).
#include "server/map/upright_box.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>

namespace loci::server {
namespace {

constexpr double kYawRad = 128.0 * M_PI / 180;

// Points (1 cm noise, map frame) of a desk top seen as an L: a strip along its front edge
// (u 0.75..1.04) and a tongue running back between the monitors (v 0.3..0.6), its top at 0.77 m,
// and a front panel down to 0.55 m.
std::vector<Eigen::Vector3d> DeskStrip(const Eigen::Vector3d& t_map_desk) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.01);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(kYawRad, Eigen::Vector3d::UnitZ()).matrix();
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < 3000; ++i) {
    Eigen::Vector3d p(0.75 + 0.29 * u01(rng), 0.3 + 0.7 * u01(rng), 0.77 + noise(rng));
    if (i % 3 == 0) p = Eigen::Vector3d(0.45 + 0.3 * u01(rng), 0.3 + 0.3 * u01(rng), p.z());
    if (i % 7 == 0) p = Eigen::Vector3d(1.04, p.y(), 0.55 + 0.22 * u01(rng));
    p.head<2>() += Eigen::Vector2d(noise(rng), noise(rng));
    pts.push_back(t_map_desk + R * p);
  }
  return pts;
}

TEST(UprightBox, ADeskStripTurnedToTheMapStandsAlongItsEdges) {
  const Eigen::Vector3d t_map_desk(250.0, -80.0, 0.0);  // far from the origin: floats hold mm
  const UprightBox box = FitUprightBox(DeskStrip(t_map_desk));
  EXPECT_NEAR(box.R_map_box.col(2).z(), 1.0, 1e-12);  // up is up
  // The longer side runs along the desk's v (0.7 m against 0.59 m across u).
  const Eigen::Vector3d v_map = Eigen::AngleAxisd(kYawRad, Eigen::Vector3d::UnitZ()) *
                                Eigen::Vector3d::UnitY();
  const double yaw_error_deg = std::acos(std::abs(box.R_map_box.col(0).dot(v_map))) * 180 / M_PI;
  std::printf("yaw error %.2f deg, half extents (%.3f, %.3f, %.3f) m\n", yaw_error_deg,
              box.half_extent_m.x(), box.half_extent_m.y(), box.half_extent_m.z());
  EXPECT_LT(yaw_error_deg, 2.0);
  EXPECT_NEAR(2 * box.half_extent_m.x(), 0.70, 0.06);
  EXPECT_NEAR(2 * box.half_extent_m.y(), 0.59, 0.06);
  const Eigen::Vector3d centre_desk =
      Eigen::AngleAxisd(-kYawRad, Eigen::Vector3d::UnitZ()) * (box.center_m - t_map_desk);
  EXPECT_NEAR(centre_desk.x(), 0.745, 0.03);
  EXPECT_NEAR(centre_desk.y(), 0.65, 0.03);
  // The box centre along those axes is the box's; along the map's it is the centre of the
  // square around the turned strip, 5 cm off along u.
  const std::vector<Eigen::Vector3d> pts = DeskStrip(t_map_desk);
  EXPECT_LT((BoxCentreAlong(pts, box.R_map_box) - box.center_m).norm(), 1e-9);
  const Eigen::Vector3d centre_map_axes = BoxCentreAlong(pts, Eigen::Matrix3d::Identity());
  EXPECT_GT((centre_map_axes - box.center_m).head<2>().norm(), 0.04);
}

TEST(UprightBox, TooFewPointsGiveAFlatBox) {
  const UprightBox one = FitUprightBox({{1.0, 2.0, 0.5}});
  EXPECT_EQ(one.half_extent_m, Eigen::Vector3d::Zero());
  EXPECT_EQ(one.center_m, Eigen::Vector3d(1.0, 2.0, 0.5));
  const UprightBox line = FitUprightBox({{0, 0, 0}, {1, 1, 0}, {2, 2, 0.2}});
  EXPECT_NEAR(line.half_extent_m.x(), std::sqrt(2.0), 1e-6);
  EXPECT_NEAR(line.half_extent_m.y(), 0.0, 1e-6);
  EXPECT_NEAR(line.half_extent_m.z(), 0.1, 1e-12);
}

}  // namespace
}  // namespace loci::server
