// One rule set decides whether two things are one physical object: a new view and a fused
// object (association), or two fused objects (merging). server/map/README.md gives the reason
// for each term; in short:
// - labels: the same most likely class, or two classes a detector confuses, which have to fit
//   each other's sizes (class data, config/classes.yaml) and be both furniture with a top or
//   neither (a piece of a desk top is never the book on it);
// - geometry, any of: the same client track within track_gate_m (the robot's tracker followed
//   the box); centroids within the position uncertainty of the nearer one's range, with
//   compatible sizes; or the smaller one's voxels lying in the other (a partial view inside its
//   object, a duplicate sharing its surface; furniture compares footprints, since one top seen
//   from near and from afar comes out centimetres apart in height).
// The score counts the geometric terms met; the best-scoring object wins, ties to the nearest.
#pragma once

#include <cstdint>
#include <set>
#include <string>
#include <utility>

#include <Eigen/Core>

#include "server/map/map_options.h"
#include "server/map/voxel_key.h"

namespace loci::server {

// What the rules read of a view or an object.
struct AssociationView {
  std::string class_name;  // the view's class, or the object's most likely one
  Eigen::Vector3d centroid_m = Eigen::Vector3d::Zero();
  double half_size_m = 0;  // largest half extent
  double range_m = 0;      // camera distance of its (nearest) view; 0: unknown
  const VoxelSet* keys = nullptr;       // voxels at FusionOptions::overlap_voxel_m
  const VoxelSet* footprint = nullptr;  // horizontal cells under them (furniture), may be null
  const std::set<std::pair<int64_t, int64_t>>* tracks = nullptr;  // (session, track id)
};

class ObjectAssociation {
 public:
  explicit ObjectAssociation(const FusionOptions& options) : options_(options) {}

  // Number of geometric terms met (0-3) when the labels allow a and b to be one object, else 0.
  int Score(const AssociationView& a, const AssociationView& b) const;

  // Furniture with a top (FusionOptions::top_classes).
  bool IsTopClass(const std::string& class_name) const;
  // An object of size_m (longest side) can be of the class (class_size_slack x max_size_m).
  bool FitsClass(const std::string& class_name, double size_m) const;
  bool SizesCompatible(double half_a_m, double half_b_m) const;
  bool LabelsAllow(const AssociationView& a, const AssociationView& b) const;
  // Centroid distance under which a and b are one by their position uncertainty.
  double CentroidGateM(const AssociationView& a, const AssociationView& b) const;

 private:
  FusionOptions options_;
};

// M = |A∩B| / (|A| + |B| - |A∩B|) of two voxel sets (0 when both are empty).
double VoxelOverlap(const VoxelSet& a, const VoxelSet& b);
// |A∩B| / min(|A|, |B|) (0 when either is empty).
double VoxelContainment(const VoxelSet& a, const VoxelSet& b);
// |A∩B| / |A|: the share of A inside B (0 when A is empty).
double Within(const VoxelSet& a, const VoxelSet& b);
// The horizontal cells (the map frame is z-up) of edge cell_m under the keys' voxels of edge
// voxel_m.
VoxelSet FootprintOfKeys(const VoxelSet& keys, double voxel_m, double cell_m);

}  // namespace loci::server
