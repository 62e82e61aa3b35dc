// Gravity-aligned geometry of map objects. The gravity frame `g` is the map frame rotated so the
// map's up direction becomes +z (R_g_map, no translation): heights are z_g, footprints are the
// (x_g, y_g) rectangles of the objects' axis-aligned boxes in g. Lengths in metres.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "common/footprint.h"
#include "common/map_object.h"
#include "common/se3.h"

namespace loci::query {

// Axis-aligned box in the gravity frame.
struct BoxG {
  Vec3d min = Vec3d::Zero();
  Vec3d max = Vec3d::Zero();
  Vec3d Size() const { return (max - min).cwiseMax(0.0); }
  Vec3d Center() const { return 0.5 * (min + max); }
  double FootprintArea() const { return Size().x() * Size().y(); }
  double Volume() const { return Size().prod(); }
};

// What the relations need of one object: id, box and centroid in g, and its size (largest side
// of the box, m).
struct ObjectGeom {
  int64_t id = 0;
  std::string class_name;
  // Height of the surface things rest on: the box top, or for flat-top furniture (tables) the
  // object's densest horizontal layer when the map knows it.
  double top_z = 0;
  // Height of its bottom: the box bottom, or the object's robust bottom (BottomZ) when the map
  // knows it.
  double bottom_z = 0;
  BoxG box;
  // The horizontal outline of its oriented box in g (footprint.h); empty without one.
  Footprint footprint_g;
  Vec3d centroid_g = Vec3d::Zero();
  double size_m = 0;
};

// A viewer in g: camera centre and horizontal forward direction (unit, z_g = 0).
struct ViewpointG {
  std::string robot;
  Vec3d position_g = Vec3d::Zero();
  Vec3d forward_g = Vec3d::UnitX();
};

// A robot's latest camera pose in the map frame, for left / right / in front / behind.
struct Viewpoint {
  std::string robot;
  SE3d T_map_cam = SE3d::Identity();
  int64_t t_ns = 0;
};

class GravityFrame {
 public:
  // `up_map`: unit up direction in the map frame (normalised here; must be non-zero).
  // flat_top_classes: furniture whose top surface is its densest horizontal layer (tables).
  explicit GravityFrame(const Vec3d& up_map,
                        std::vector<std::string> flat_top_classes = {"dining table", "desk",
                                                                     "bench", "bed"});

  const Vec3d& up_map() const { return up_map_; }
  const Mat3d& R_g_map() const { return R_g_map_; }
  bool is_identity() const { return identity_; }

  Vec3d ToG(const Vec3d& p_map) const { return R_g_map_ * p_map; }
  Vec3d ToMap(const Vec3d& p_g) const { return R_g_map_.transpose() * p_g; }

  // Box of the object in g: its map AABB when up is the map z, else the g-AABB of its oriented
  // box (or of its map AABB corners when the oriented box is empty).
  ObjectGeom Geom(const MapObject& object) const;
  // Camera centre and horizontal viewing direction (camera z, or camera -y when looking straight
  // down or up) in g. nullopt when the pose is not finite.
  std::optional<ViewpointG> View(const Viewpoint& viewpoint) const;

 private:
  Vec3d up_map_;
  Mat3d R_g_map_;
  bool identity_ = false;
  std::vector<std::string> flat_top_classes_;
};

// Area (m^2) of the intersection of the two footprints.
double FootprintOverlapArea(const BoxG& a, const BoxG& b);
// Euclidean gap between two boxes (0 when they touch or intersect), m.
double BoxGap(const BoxG& a, const BoxG& b);
// Gap between the two footprints in the horizontal plane, m.
double HorizontalGap(const BoxG& a, const BoxG& b);
// Volume of the intersection of two boxes, m^3.
double IntersectionVolume(const BoxG& a, const BoxG& b);

// Up direction estimated from the viewpoints' camera -y axes (cameras are held roughly level):
// nullopt when there are none or they disagree (mean of unit vectors shorter than 0.5).
std::optional<Vec3d> EstimateUpFromViewpoints(const std::vector<Viewpoint>& viewpoints);

}  // namespace loci::query
