// Top surfaces of one view of flat-topped furniture (a table, a desk, a bench), to tell apart
// pieces of furniture that one detector box covers (two desks back to back, a row of tables) and
// to keep what is not the furniture out of its observation.
//
// A table top is a flat, level surface: the top surfaces are the horizontal planes of the view's
// points (RANSAC, normal within max_tilt_deg of up) and, on each plane, the connected regions of
// its footprint (cell_m grid across up) that cover at least min_top_area_m2. A lower region
// whose footprint lies mostly under a higher one is a shelf of the same furniture, not a top.
// Every point then belongs to the top whose footprint is horizontally nearest, within reach_m,
// unless it rises more than MaskOptions::flat_top_margin_m above that top (something standing on
// it): what is outside every footprint is not this furniture.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <unordered_set>
#include <vector>

#include "detection/depth_mask.h"

namespace loci::server {

struct SupportTopsOptions {
  // On (default): one observation per top, so one box over two tables gives two. Off:
  // furniture observations are kept whole, as the detector's mask or box gave them.
  bool enabled = true;
  // Footprint grid edge, m: coarser than depth noise and the object voxels (1-3 cm on a table
  // seen at 1-3 m), finer than any table top (0.05).
  double cell_m = 0.05;
  // Largest angle between a top's normal and up, deg: gravity from an accelerometer is good to
  // 1-3 deg while the camera moves, and a furniture top is level to about 1 deg (5).
  double max_tilt_deg = 5.0;
  // Smallest top that counts as a piece of furniture, m^2: a small side table is 0.4 x 0.4 m;
  // one view often shows only half of a top (0.08).
  double min_top_area_m2 = 0.08;
  // A point belongs to a top whose footprint is within this horizontal distance, m: the front
  // face, legs and rims hang under the top's edge, seen one or two cells off (0.1).
  double reach_m = 0.1;
  // Horizontal planes tried per view (tops at different heights) (4).
  int max_planes = 4;
  // RANSAC samples per plane (deterministic sequence) (200).
  int ransac_iterations = 200;
  // A footprint cell lies on a plane when at least half of its points are within this share of
  // the plane's tolerance (detection::PlaneToleranceM: 2.5 sigma of the depth noise) of it: the
  // plane runs through the surface in that cell, not beside it. Two tops a few centimetres apart
  // (desks back to back) both lie in the band of a plane halfway between them, about half of
  // each cell's points inside; when every cell with any inlier counted, that plane's one region
  // over both tops was the largest, and the two desks made one top in views from 2 m and more.
  // 0.5 (~1.25 sigma) keeps them apart out to about 2.7 m. <= 0: any inlier puts its cell on
  // the plane (0.5).
  double cell_band_share = 0.5;
};

// The tops of one view's points (camera frame) of a flat-topped furniture detection.
class SupportTops {
 public:
  // up_kf: unit up (minus gravity) in the same frame as the points. mask: the inlier tolerance
  // of a plane at each depth (detection::PlaneToleranceM) and flat_top_margin_m.
  SupportTops(const std::vector<Eigen::Vector3d>& points_kf, const Eigen::Vector3d& up_kf,
              const SupportTopsOptions& options, const detection::MaskOptions& mask);

  size_t size() const { return tops_.size(); }
  // Mean height (along up) of top i's points, m.
  double HeightM(size_t i) const { return tops_[i].height_m; }
  // Index of the top the point belongs to, -1 when none (see the file comment).
  int TopOf(const Eigen::Vector3d& p_kf) const;

 private:
  struct Top {
    Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
    double offset_m = 0;  // normal . p on the plane
    double height_m = 0;  // up . p of its points, mean
    std::unordered_set<int64_t> cells;
  };
  int64_t CellOf(const Eigen::Vector3d& p) const;
  // Adds the tops of one plane's inliers (its connected footprint regions large enough).
  void AddPlaneTops(const std::vector<Eigen::Vector3d>& inliers, const Eigen::Vector3d& normal,
                    double offset_m);

  void DropShelves();

  SupportTopsOptions options_;
  double margin_m_;
  Eigen::Vector3d up_, e1_, e2_;
  std::vector<Top> tops_;
};

}  // namespace loci::server
