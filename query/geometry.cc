#include "query/geometry.h"

#include <algorithm>
#include <cmath>

namespace loci::query {
namespace {

double IntervalOverlap(double a0, double a1, double b0, double b1) {
  return std::max(0.0, std::min(a1, b1) - std::max(a0, b0));
}
double IntervalGap(double a0, double a1, double b0, double b1) {
  return std::max(0.0, std::max(a0, b0) - std::min(a1, b1));
}

}  // namespace

GravityFrame::GravityFrame(const Vec3d& up_map, std::vector<std::string> flat_top_classes)
    : flat_top_classes_(std::move(flat_top_classes)) {
  up_map_ = up_map.norm() > 1e-9 ? up_map.normalized() : Vec3d::UnitZ();
  identity_ = (up_map_ - Vec3d::UnitZ()).norm() < 1e-9;
  R_g_map_ = identity_ ? Mat3d::Identity() : RotationAligningToZ(up_map_);
}

ObjectGeom GravityFrame::Geom(const MapObject& o) const {
  ObjectGeom g;
  g.id = o.id;
  g.class_name = o.class_name;
  if (identity_) {
    g.box.min = o.aabb_min_m.cwiseMin(o.aabb_max_m);
    g.box.max = o.aabb_min_m.cwiseMax(o.aabb_max_m);
    g.centroid_g = o.centroid_m;
  } else {
    const bool use_obb = o.obb_half_extent_m.maxCoeff() > 0;
    const Vec3d c = use_obb ? o.obb_center_m : 0.5 * (o.aabb_min_m + o.aabb_max_m);
    const Vec3d h = use_obb ? Vec3d(o.obb_half_extent_m.cwiseAbs())
                            : Vec3d((0.5 * (o.aabb_max_m - o.aabb_min_m)).cwiseAbs());
    const Mat3d R = use_obb ? Mat3d(R_g_map_ * o.R_map_box) : R_g_map_;
    // Half extent of a rotated box along each g axis: sum_j |R_ij| h_j.
    const Vec3d half_g = R.cwiseAbs() * h;
    const Vec3d c_g = R_g_map_ * c;
    g.box.min = c_g - half_g;
    g.box.max = c_g + half_g;
    g.centroid_g = R_g_map_ * o.centroid_m;
  }
  g.footprint_g = OrientedFootprint(o, R_g_map_);
  g.size_m = g.box.Size().maxCoeff();
  g.top_z = g.box.max.z();
  g.bottom_z = identity_ ? BottomZ(o) : g.box.min.z();
  if (identity_ && std::isfinite(o.top_surface_z_m) &&
      std::find(flat_top_classes_.begin(), flat_top_classes_.end(), o.class_name) !=
          flat_top_classes_.end() &&
      o.top_surface_z_m > g.box.min.z() && o.top_surface_z_m <= g.box.max.z()) {
    g.top_z = o.top_surface_z_m;
  }
  return g;
}

std::optional<ViewpointG> GravityFrame::View(const Viewpoint& v) const {
  if (!IsFinite(v.T_map_cam)) return std::nullopt;
  ViewpointG out;
  out.robot = v.robot;
  const Mat3d R_g_cam = R_g_map_ * v.T_map_cam.linear();
  out.position_g = R_g_map_ * v.T_map_cam.translation();
  Vec3d f = R_g_cam.col(2);
  f.z() = 0;
  if (f.norm() < 0.2) {  // looking (almost) straight down or up: the image top is "forward"
    f = -R_g_cam.col(1);
    f.z() = 0;
  }
  if (f.norm() < 1e-9) return std::nullopt;
  out.forward_g = f.normalized();
  return out;
}

double FootprintOverlapArea(const BoxG& a, const BoxG& b) {
  return IntervalOverlap(a.min.x(), a.max.x(), b.min.x(), b.max.x()) *
         IntervalOverlap(a.min.y(), a.max.y(), b.min.y(), b.max.y());
}

double BoxGap(const BoxG& a, const BoxG& b) {
  const Vec3d d(IntervalGap(a.min.x(), a.max.x(), b.min.x(), b.max.x()),
                IntervalGap(a.min.y(), a.max.y(), b.min.y(), b.max.y()),
                IntervalGap(a.min.z(), a.max.z(), b.min.z(), b.max.z()));
  return d.norm();
}

double HorizontalGap(const BoxG& a, const BoxG& b) {
  return std::hypot(IntervalGap(a.min.x(), a.max.x(), b.min.x(), b.max.x()),
                    IntervalGap(a.min.y(), a.max.y(), b.min.y(), b.max.y()));
}

double IntersectionVolume(const BoxG& a, const BoxG& b) {
  return FootprintOverlapArea(a, b) * IntervalOverlap(a.min.z(), a.max.z(), b.min.z(), b.max.z());
}

std::optional<Vec3d> EstimateUpFromViewpoints(const std::vector<Viewpoint>& viewpoints) {
  Vec3d sum = Vec3d::Zero();
  int n = 0;
  for (const Viewpoint& v : viewpoints) {
    if (!IsFinite(v.T_map_cam)) continue;
    sum += -v.T_map_cam.linear().col(1).normalized();
    ++n;
  }
  if (n == 0 || sum.norm() / n < 0.5) return std::nullopt;
  return sum.normalized();
}

}  // namespace loci::query
