// Options of the server's map: dense cloud, object observations, object fusion, OctoMap.
// Every field documents its unit and default; FromYaml reads only the keys present.
#pragma once

#include <yaml-cpp/yaml.h>

#include <map>
#include <string>
#include <vector>

#include "common/status.h"
#include "detection/depth_mask.h"
#include "server/map/map_frame.h"
#include "server/map/support_tops.h"
#include "server/map/visibility.h"

namespace loci::server {

// Dense semantic cloud of a keyframe (paper 000 3.2-3.3).
struct CloudOptions {
  double min_depth_m = 0.1;     // nearer depth readings are ignored (default 0.1)
  double max_depth_m = 4.0;     // farther readings are ignored: Kinect noise grows with z^2 (4.0)
  int pixel_stride = 2;         // back-project every n-th pixel in u and v for the dense cloud (2)
  double voxel_m = 0.04;        // voxel filter edge for the keyframe and global cloud, m (0.04)
  int sor_mean_k = 8;           // statistical outlier removal: neighbours per point, K (8)
  double sor_stddev_mul = 1.0;  // eq. 18 threshold t = m + k * s: this is k (1.0)
};

// Object observations in a keyframe (paper 002 3.3: box + depth segmentation, or the mask).
struct ObservationOptions {
  double min_score = 0.2;  // detections below this score are ignored (0.2)
  // Object pixels of a detection that comes without a mask (detection::SegmentObjectDepth;
  // depth_scale is unused: the server works in metres). Its keys are the detection module's.
  detection::MaskOptions mask;
  double voxel_m = 0.01;  // voxel filter edge of object clouds, m (0.01)
  // Large objects (tables) are voxelised coarser so that one view gives at most about this many
  // voxels: edge = max(voxel_m, sqrt(visible area / max_points)) (2000).
  int max_points = 2000;
  int sor_mean_k = 10;          // outlier removal on object clouds, K (10)
  double sor_stddev_mul = 1.0;  // outlier removal on object clouds, k of eq. 18 (1.0)
  // Floor of the eq. 18 threshold in object voxel edges: a point goes only when its mean
  // distance to its K neighbours also exceeds this many voxels. Edge and corner points of a
  // clean surface sit at 1.6-2.1 edges (K = 10), strays much farther (3.0).
  double sor_min_voxels = 3.0;
  int min_points = 20;  // observations with fewer filtered points are dropped (20)
  // Observation quality: a detector's precision falls on small boxes and Kinect-class depth
  // noise grows with z^2, so boxes whose shorter side is below min_box_px (20) and objects whose
  // median depth is beyond max_object_depth_m (3.5 m) are not fused.
  double min_box_px = 20;
  double max_object_depth_m = 3.5;
  // Depth support (mask_cover.h): a mask that covers less than this share of its box's middle
  // half, and less there than on the whole box, is a ring around something without depth (a dark
  // screen at a slant, the wall around it): not fused. Furniture with a top is exempt (its box
  // middle is what stands on it). 0: off (0.3).
  double min_centre_cover = 0.3;
  // Furniture with a top (config/classes.yaml `top`) seen with gravity: one observation per top
  // surface, without what lies outside the tops' footprints (support_tops.h).
  SupportTopsOptions support_tops;
};

// Object fusion (paper 000 3.3, paper 004 III.D): association and merging by one rule set
// (object_association.h), shape from view-supported voxels, labels by Bayes' rule, existence as
// a log-odds belief. server/map/README.md gives the reason for each term.
struct FusionOptions {
  // Association and merging (object_association.h).
  double overlap_voxel_m = 0.03;  // voxel edge of the containment test, m (0.03)
  // Share of the smaller one's voxels inside the other (a partial view inside its object, a
  // duplicate sharing its surface) (0.5).
  double containment = 0.5;
  // Centroids closer than max(centroid_gate_m, gate_sigmas * sqrt(2) s(r)) are one object, with
  // s(r)^2 = (depth_sigma_at_1m r^2)^2 + (view_sigma_rad r)^2 at the nearer one's range r
  // (0.1 m, 1.0, 0.01 m, 0.026 rad).
  double centroid_gate_m = 0.1;
  double gate_sigmas = 1.0;
  double depth_sigma_at_1m = 0.01;
  double view_sigma_rad = 0.026;
  double track_gate_m = 0.5;    // the same client track counts within this distance, m (0.5)
  double max_size_ratio = 2.0;  // sizes compatible: larger half extent <= this x smaller (2)
  // A fused box is the union of many views: an object of another class, or a confirmed one of
  // its own, may be up to this x its class's max_size_m (config/classes.yaml) (1.5).
  double class_size_slack = 1.5;
  // Shape: voxels in support_cell_m cells (0.05) that at least
  // max(2, ceil(min_support_fraction * observations)) observations saw (0.25), from the views of
  // the most likely class once it has shape_min_label_views of them (3).
  double support_cell_m = 0.05;
  double min_support_fraction = 0.25;
  int shape_min_label_views = 3;
  // An object's bottom (the query's "on") is this quantile of its shape voxels' heights (0.05).
  double bottom_quantile = 0.05;
  // Labels (label_distribution.h): K classes, scores clamped to [min_likelihood, 1 - it].
  int label_universe = 13;
  double min_likelihood = 0.05;
  // Existence (FusedObject::ExistenceLogOdds): the prior probability of a new object, the
  // probability that a real object is boxed in a time window of evidence_window_s whose views
  // should show it, that a false box recurs at its place in such a window, and the beliefs at
  // which an object is confirmed and removed (0.03, 0.5, 0.1, 0.5 s, 0.5, 0.02). The belief
  // is held at or below max_belief (0.97, OctoMap's clamping), so a place seen empty for a
  // bounded time always removes what stood there, however long it was seen before.
  double existence_prior = 0.03;
  double p_detect = 0.5;
  double p_false = 0.1;
  double evidence_window_s = 0.5;
  double confirm_belief = 0.5;
  double remove_belief = 0.02;
  double max_belief = 0.97;
  VisibilityOptions visibility;
  // Class data (config/classes.yaml, set by Mapper): furniture with a top, size limits.
  std::vector<std::string> top_classes;
  double top_margin_m = 0.03;
  std::map<std::string, double> max_size_m;
  std::map<std::string, double> max_thickness_m;
  std::map<std::string, double> stays_s;  // mean time a thing of the class stays put, s
};

struct OctomapOptions {
  bool enabled = true;
  double resolution_m = 0.05;  // leaf size, m (0.05)
  double max_range_m = 4.0;    // rays are truncated at this range, m; <= 0 = none (4.0)
  // Free space is carved by rays to one end point per ray voxel of this edge; the other end
  // points are marked occupied without a ray (ray casting dominates the cost). <= resolution_m
  // = a ray to every end point (0.1).
  double ray_voxel_m = 0.1;
  // A pose update rebuilds the OctoMap (from every keyframe's products) only when some
  // keyframe's scan would move more than this since it went into the tree: its translation plus
  // its rotation (rad) times max_range_m (4 m when max_range_m <= 0), m. 0: every update that
  // moves a keyframe (0.0125, a quarter of the default leaf).
  double rebuild_tolerance_m = 0.0125;
};

struct MapOptions {
  MapFrameOptions frame;
  CloudOptions cloud;
  ObservationOptions observation;
  FusionOptions fusion;
  OctomapOptions octomap;
  // Classes whose pixels never enter the cloud, the OctoMap or the object database (person...).
  std::vector<std::string> dynamic_classes = {"person", "dog", "cat"};
  // Classes kept in the object database; empty = every class.
  std::vector<std::string> mapped_classes;
  // Largest plausible extent of one view of a class, m (config/classes.yaml `max_size_m`);
  // larger observations are dropped. Absent = no limit.
  std::map<std::string, double> max_size_m;
  // Largest plausible height of one view of a class seen with gravity, m (config/classes.yaml
  // `max_height_m`: the 5-95 % extent of its points along up); taller observations are dropped.
  // Absent = no limit.
  std::map<std::string, double> max_height_m;
  // Thickest plausible fused object of a class, m (config/classes.yaml `max_thickness_m`: the
  // thinnest side of its oriented box). Absent = no limit.
  std::map<std::string, double> max_thickness_m;
  // The stand or feet a class stands on that its points leave out, m (config/classes.yaml
  // `stand_m`: a flat panel's stand): the query's "on" allows for it. Absent = none.
  std::map<std::string, double> stand_m = {{"tv", 0.25}};
  // Mean time a thing of the class stays where it is, days (config/classes.yaml `stays_days`):
  // the existence belief forgets at this rate (FusedObject::ExistenceModel). Absent = forever.
  std::map<std::string, double> stays_days;

  // Reads the sections cloud / observation / fusion / octomap and the class lists.
  // Fingerprints of what the stored map was made with (stored beside it; another fingerprint
  // makes the server recompute): the products' (cloud, observation, classes, the visibility
  // depth stride, a code version) and the whole map's (every option). Built from the YAML the
  // options were read from, so a default that changes in code must bump kMapCodeVersion.
  std::string ProductsFingerprint() const;
  std::string MapFingerprint() const;
  // Adds an input of the products that is not a map option (the server detector's options).
  void NoteProductsInput(const std::string& text) { products_yaml_ += text; }

  Status FromYaml(const YAML::Node& node);
  // Reads config/classes.yaml: `mapped`, `dynamic_classes`, `top` (furniture with a top,
  // into observation.mask.flat_top_classes) and the per-class sizes.
  Status ClassesFromYaml(const YAML::Node& node);
  Status Validate() const;
  // The documented option tables as YAML (`loci-server --print-options`), defaults filled in.
  static std::string DefaultsYaml();
  // The same with these options' values.
  std::string ValuesYaml() const;
  // How many keys the option tables declare (the map's options, without the detection
  // module's mask keys).
  static size_t OptionCount();
  bool IsDynamic(const std::string& class_name) const;
  bool IsMapped(const std::string& class_name) const;
  // max_size_m of the class, or infinity.
  double MaxSizeM(const std::string& class_name) const;
  // max_height_m of the class, or infinity.
  double MaxHeightM(const std::string& class_name) const;

 private:
  std::string products_yaml_;  // the YAML text FromYaml / ClassesFromYaml read, per concern
  std::string map_yaml_;
};

// Version of the product and fusion code; bump it when a change alters products or the map
// for the same options (stored products and checkpoints of another version are recomputed).
inline constexpr int kMapCodeVersion = 17;

}  // namespace loci::server
