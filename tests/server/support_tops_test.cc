// Top surfaces of flat-topped furniture (server/map/support_tops.h): two desks back to back with
// tops 4 cm apart are two tops, one desk with its legs, a shelf and a cup on it is one.
#include <gtest/gtest.h>

#include <random>

#include "server/map/support_tops.h"

namespace loci::server {
namespace {

using Points = std::vector<Eigen::Vector3d>;

// A level rectangle [x0, x1] x [y0, y1] at height z (z up), points every step_m.
void AddTop(double x0, double x1, double y0, double y1, double z, Points* out,
            double step_m = 0.02) {
  for (double x = x0; x <= x1; x += step_m) {
    for (double y = y0; y <= y1; y += step_m) out->emplace_back(x, y, z);
  }
}

// A vertical post from z0 to z1 at (x, y).
void AddPost(double x, double y, double z0, double z1, Points* out) {
  for (double z = z0; z <= z1; z += 0.02) out->emplace_back(x, y, z);
}

// Plane tolerance 8 mm at every depth (the points here are in a z-up frame, not a camera's).
SupportTopsOptions On() {
  SupportTopsOptions o;
  o.enabled = true;
  return o;
}

detection::MaskOptions Mask() {
  detection::MaskOptions m;
  m.plane_tolerance_sigma = 0;
  return m;
}

TEST(SupportTops, TwoDesksBackToBackFourCentimetresApartAreTwoTops) {
  Points pts;
  AddTop(0.0, 0.9, 0.0, 1.5, 0.75, &pts);     // desk A
  AddTop(-0.92, -0.02, 0.0, 1.5, 0.71, &pts);  // desk B, 2 cm gap, 4 cm lower
  const SupportTops tops(pts, Eigen::Vector3d::UnitZ(), On(), Mask());
  ASSERT_EQ(tops.size(), 2u);
  const int a = tops.TopOf({0.5, 0.7, 0.75}), b = tops.TopOf({-0.5, 0.7, 0.71});
  EXPECT_GE(a, 0);
  EXPECT_GE(b, 0);
  EXPECT_NE(a, b);
  // A leg under desk B's far edge and its front face belong to desk B.
  EXPECT_EQ(tops.TopOf({-0.9, 0.1, 0.3}), b);
  EXPECT_EQ(tops.TopOf({0.88, 0.1, 0.3}), a);
}

// Points of a z-up scene as a camera at `centre_world`, looking along `forward_world`, sees them
// (x right, y down, z forward), with depth noise along each ray of 0.0015 z^2 (Kinect).
Points SeenFrom(const Points& world, const Eigen::Vector3d& centre_world,
                const Eigen::Vector3d& forward_world, std::mt19937* rng,
                Eigen::Vector3d* up_cam) {
  const Eigen::Vector3d z_c = forward_world.normalized();
  const Eigen::Vector3d x_c = z_c.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d y_c = z_c.cross(x_c);
  Eigen::Matrix3d R_cam_world;
  R_cam_world << x_c.transpose(), y_c.transpose(), z_c.transpose();
  *up_cam = R_cam_world * Eigen::Vector3d::UnitZ();
  std::normal_distribution<double> unit(0.0, 1.0);
  Points cam;
  for (const Eigen::Vector3d& p : world) {
    const Eigen::Vector3d q = R_cam_world * (p - centre_world);
    const double z = q.z(), noisy_z = z + 0.0015 * z * z * unit(*rng);
    cam.push_back(q * (noisy_z / z));
  }
  return cam;
}

// Two desks back to back, touching, tops 3 cm apart (fr1_rpy's), seen from 1.2-2.9 m away with
// Kinect depth noise and the mask's depth-dependent plane band (2.5 sigma): two tops, and one desk
// seen the same way stays one top (cell_band_share does not break a noisy top into pieces).
TEST(SupportTops, TwoTouchingDesksThreeCentimetresApartSeenFromAfarAreTwoTops) {
  std::mt19937 rng(3);
  Points world;
  AddTop(0.0, 0.9, 0.0, 1.5, 0.77, &world);    // desk A
  AddTop(-0.92, -0.02, 0.0, 1.5, 0.74, &world);  // desk B, back to back, 3 cm lower
  Eigen::Vector3d up_cam;
  const Eigen::Vector3d camera(1.9, 0.75, 1.45), forward(-1.0, 0.0, -0.7);
  const Points pts = SeenFrom(world, camera, forward, &rng, &up_cam);
  const detection::MaskOptions mask;  // the default band: max(8 mm, 2.5 x 0.0015 z^2)
  const SupportTops tops(pts, up_cam, On(), mask);
  ASSERT_EQ(tops.size(), 2u);
  Eigen::Vector3d unused;
  const Points probes = SeenFrom({{0.5, 0.7, 0.77}, {-0.5, 0.7, 0.74}}, camera, forward, &rng,
                                 &unused);
  const int a = tops.TopOf(probes[0]), b = tops.TopOf(probes[1]);
  EXPECT_GE(a, 0);
  EXPECT_GE(b, 0);
  EXPECT_NE(a, b);
  // One desk seen the same way stays one top, its far cells included.
  Points one;
  AddTop(0.0, 0.9, 0.0, 1.5, 0.77, &one);
  const Points one_cam = SeenFrom(one, camera, forward, &rng, &up_cam);
  const SupportTops one_top(one_cam, up_cam, On(), mask);
  ASSERT_EQ(one_top.size(), 1u);
  size_t on_top = 0;
  for (const Eigen::Vector3d& p : one_cam) on_top += one_top.TopOf(p) == 0;
  EXPECT_GT(on_top, 0.97 * static_cast<double>(one_cam.size()));
}

TEST(SupportTops, OneTableWithLegsShelfAndCupIsOneTopThatKeepsLegsAndDropsTheCup) {
  Points pts;
  AddTop(0.0, 1.2, 0.0, 0.8, 0.75, &pts);
  AddTop(0.1, 1.1, 0.1, 0.7, 0.30, &pts);  // a shelf under the top
  for (double x : {0.02, 1.18}) {
    for (double y : {0.02, 0.78}) AddPost(x, y, 0.0, 0.74, &pts);
  }
  const SupportTops tops(pts, Eigen::Vector3d::UnitZ(), On(), Mask());
  ASSERT_EQ(tops.size(), 1u);
  EXPECT_EQ(tops.TopOf({0.02, 0.02, 0.1}), 0);   // a leg
  EXPECT_EQ(tops.TopOf({0.5, 0.4, 0.30}), 0);    // the shelf
  EXPECT_EQ(tops.TopOf({0.5, 0.4, 0.85}), -1);   // a cup standing on it
  EXPECT_EQ(tops.TopOf({1.6, 0.4, 0.75}), -1);   // beyond its footprint: something else
}

TEST(SupportTops, TwoTablesAtOneHeightWithAGapAreTwoTops) {
  Points pts;
  AddTop(0.0, 0.8, 0.0, 0.8, 0.72, &pts);
  AddTop(1.2, 2.0, 0.0, 0.8, 0.72, &pts);
  const SupportTops tops(pts, Eigen::Vector3d::UnitZ(), On(), Mask());
  EXPECT_EQ(tops.size(), 2u);
}

TEST(SupportTops, NoLevelTopOrDisabledMeansNoTops) {
  Points wall;
  for (double y = 0; y <= 1.0; y += 0.02) AddPost(0.0, y, 0.0, 1.0, &wall);
  EXPECT_EQ(SupportTops(wall, Eigen::Vector3d::UnitZ(), On(), Mask()).size(), 0u);
  Points top;
  AddTop(0.0, 1.0, 0.0, 1.0, 0.7, &top);
  EXPECT_TRUE(SupportTopsOptions{}.enabled);  // on by default
  SupportTopsOptions off;
  off.enabled = false;
  EXPECT_EQ(SupportTops(top, Eigen::Vector3d::UnitZ(), off, Mask()).size(), 0u);
  // Too small to be furniture (a 20 x 20 cm patch).
  Points patch;
  AddTop(0.0, 0.2, 0.0, 0.2, 0.7, &patch);
  EXPECT_EQ(SupportTops(patch, Eigen::Vector3d::UnitZ(), On(), Mask()).size(), 0u);
}

}  // namespace
}  // namespace loci::server
