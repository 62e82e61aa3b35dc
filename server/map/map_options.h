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
#include "server/map/top_loads.h"
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
  // depth_scale is unused: the server works in metres).
  detection::MaskOptions mask;
  double voxel_m = 0.01;  // voxel filter edge of object clouds, m (0.01)
  // Large objects (tables) are voxelised coarser so that one view gives at most about this many
  // voxels: edge = max(voxel_m, sqrt(visible area / max_points)) (2000).
  int max_points = 2000;
  int sor_mean_k = 10;          // outlier removal on object clouds, K (10)
  double sor_stddev_mul = 1.0;  // outlier removal on object clouds, k of eq. 18 (1.0)
  // Floor of the eq. 18 threshold in object voxel edges: a point goes only when its mean
  // distance to its K neighbours also exceeds this many voxels. Edge and corner points of a
  // clean surface sit at 1.6-2.1 edges (K = 10), strays much farther; without the floor every
  // view loses its rim and the fused box shrinks where only rims reach (the far side) (3.0).
  double sor_min_voxels = 3.0;
  int min_points = 20;  // observations with fewer filtered points are dropped (20)
  // Observation quality: boxes whose shorter side is below min_box_px (20) and objects whose
  // median depth is beyond max_object_depth_m (3.5 m; Kinect-class depth noise grows with z^2
  // and a detector's precision falls on small, far boxes) are not fused.
  double min_box_px = 20;
  double max_object_depth_m = 3.5;
  // Depth support (mask_cover.h): a mask that covers less than this share of its box's middle
  // half, and less there than on the whole box, is a ring around something without depth (a dark
  // screen at a slant, the wall around it): not fused. Flat-topped furniture is exempt (its box
  // middle is often what stands on it). 0: off (0.3).
  double min_centre_cover = 0.3;
  // Flat-topped furniture (mask.flat_top_classes) seen with gravity: one observation per top
  // surface, without what lies outside the tops' footprints (support_tops.h).
  SupportTopsOptions support_tops;
  // Small flat objects that lie side by side or on each other (books): one detector box often
  // covers two of them. Seen with gravity, a box of one of these classes whose points hold two
  // or more level tops of different footprints gives one observation per top (support_tops.h,
  // these options); with one top it stays whole. Empty classes: off.
  struct ObjectTops {
    std::vector<std::string> classes = {"book"};
    // A book's top is at least about 0.1 x 0.1 m; 2 cm cells resolve it at 1-3 m; its side
    // faces hang under the top's edge within a cell or two; books lie level to a few degrees.
    SupportTopsOptions tops = {
        /*enabled=*/true,          /*cell_m=*/0.02,        /*max_tilt_deg=*/8.0,
        /*min_top_area_m2=*/0.01,  /*reach_m=*/0.03,       /*max_planes=*/3,
        /*ransac_iterations=*/200, /*cell_band_share=*/0.5};
    // The tops must differ in height by at least this, m: a step between two objects (books
    // 2-8 cm thick), not the two pages of one open book or two parts of one cover (0.015).
    double min_step_m = 0.015;
    bool Applies(const std::string& class_name) const;
  } object_tops;
};

// Association of observations with objects and merging (paper 000 3.3).
struct FusionOptions {
  double max_centroid_distance_m = 0.1;  // centroid criterion: distance below this, m (0.1)
  // Object centroid: true (default) = centre of the axis-aligned box of the fused points, false =
  // mean of the fused points (paper 000 eq. 16). A robot sees the top and the near side of an
  // object, so the point mean is pulled towards the camera while the box centre is not.
  bool centroid_from_box = true;
  double min_overlap = 0.8;       // overlap criterion: M = |A∩B| / |A∪B| above this (0.8)
  double overlap_voxel_m = 0.03;  // voxel edge used for M, m (0.03)
  double weight_track = 0.5;      // score weight of "same session and track id" (0.5)
  double weight_centroid = 0.5;   // score weight of the centroid criterion (0.5)
  double weight_overlap = 0.5;    // score weight of the overlap criterion (0.5)
  double score_threshold = 0.5;   // associate when the weighted score reaches this (0.5)
  double track_gate_m = 0.5;      // a track id match counts only within this distance, m (0.5)
  int confirm_observations = 3;   // an object is confirmed after this many keyframes (3)
  // ... seen over at least this long, first to last detection, s (0.5). Detector errors come in
  // bursts (a blurred swing, a glare): three keyframes 0.1 s apart are one piece of evidence,
  // not three; a real object stays in view longer, or is seen again. 0: off.
  double confirm_min_span_s = 0.5;
  // Flat-topped furniture: a view of which at least this share of the voxels lies in each of two
  // or more such objects of the map straddles them (one box over two desks back to back, one
  // plane through both tops): it is left out instead of joining them (0.25), when two of them lie
  // apart (neither's footprint lies by this share on the other). 0: off.
  double straddle_share = 0.25;
  // Pieces of furniture that at least this many views straddled (straddle_share) never merge,
  // whatever their voxels share later (a piece grew between them, a pose moved): those views
  // were left out because the map held the two apart, and a merge would undo that. 0: off (the
  // default: measured mixed on fr1_rpy, docs/results.md session 29).
  int straddle_apart_views = 0;
  // A piece of such furniture whose footprint lies across two others by straddle_share each
  // (both confirmed, apart from each other, each seen at least as often as the piece) stays a
  // candidate while it does: it is the views of one box over both, fused before the two stood
  // apart in the map (object_straddlers.cc). false: off.
  bool straddle_pieces = true;
  // A table's footprint runs on under the confirmed objects resting on its top (top_loads.h):
  // objects, answers and exports show the whole top, not the strip between the things on it.
  // fusion.top_load_reach_m (0.15, 0 = off) and fusion.top_load_max_gap_m (0.05).
  TopLoadOptions top_loads;
  // Two objects with the same argmax class merge when their centroids are closer than
  // merge_centroid_m (0.1) or when |A∩B| / min(|A|, |B|) exceeds merge_containment (0.5). A and
  // B are the voxels that shape each object (SupportOptions: its own class's views, cells seen
  // more than once), not every view fused in: "laptop" views of a monitor and the keyboard before
  // it, fused into the keyboard, do not make it hold the monitor (session 41). Flat-topped
  // furniture, pieced together from partial views, compares all its voxels.
  double merge_centroid_m = 0.1;
  double merge_containment = 0.5;
  // The same containment for two pieces of flat-topped furniture (0.85): a one-view piece that
  // lies half inside a table adds its other half to it, and such pieces let one desk creep over
  // the desk beside it (fr1_rpy, docs/results.md session 29). 0: merge_containment.
  double furniture_merge_containment = 0.85;
  // Two pieces of flat-topped furniture also merge when this share of the smaller one's
  // footprint (horizontal cells of overlap_voxel_m under its voxels) lies under the other and
  // neither lies across two tables (straddle_pieces): views of one desk from afar and from near
  // see its top a few centimetres apart in height, and their voxels do not meet (0 = off;
  // config/server.yaml sets 0.6).
  double furniture_footprint_containment = 0.0;
  // Association ignores the class; so can merging: objects of other argmax classes merge by the
  // same rules when their sizes are compatible (true).
  bool merge_across_classes = true;
  // An observation also meets the overlap criterion when more than assoc_containment of its
  // voxels lie inside the object (a partial view) and the sizes are compatible; 1 = off (0.6).
  double assoc_containment = 0.6;
  // Sizes are compatible when the larger half extent is at most this many times the smaller (2).
  double max_size_ratio = 2.0;
  // Object geometry from voxels in support_cell_m (0.05) cells that at least
  // max(2, ceil(min_support_fraction * observations)) observations saw, from 3 observations on
  // (FusedObject SupportOptions); min_support_fraction 0 = every voxel (0.25).
  double support_cell_m = 0.05;
  double min_support_fraction = 0.25;
  // The box-centre centroid ignores disconnected parts of the supported points smaller than
  // this fraction of them (FusedObject SupportOptions); 0 = the full box (0.05).
  double centroid_min_part = 0.05;
  // An object's bottom height (MapObject::bottom_z_m, for the query's relations) is this
  // quantile of those voxels' heights: the few points a box catches under a thing (its
  // support's edge) do not lower it (FusedObject SupportOptions; 0 = the box's bottom) (0.05).
  // The top-load rules keep the box's bottom (top_load_max_sink_m allows for those points).
  double bottom_quantile = 0.05;
  // Once an object's most likely class has this many observations with points, only those
  // shape it (support cells, centroid, boxes); views of other classes fused in still count for
  // its label and existence. 0 = every observation shapes it (3).
  int shape_min_label_views = 3;
  int label_universe = 13;       // K, classes the detector can report (mapped classes) (13)
  double min_likelihood = 0.05;  // detection scores are clamped to [this, 1 - this] (0.05)
  // Existence from negative evidence (visibility.h): every keyframe that should have seen an
  // object but did not is a miss. Existence is the log-likelihood ratio of "real, detected in a
  // view with probability existence_p_real (0.15)" against "false, a box that recurs with
  // probability existence_p_false (0.03)": each hit adds log(0.15/0.03) = 1.61, each miss
  // log(0.85/0.97) = -0.13. An object is confirmed with at least confirm_observations hits and
  // an LLR >= confirm_llr (2.0); it is removed when the LLR falls to remove_llr (-4.0).
  double existence_p_real = 0.15;
  double existence_p_false = 0.03;
  // Per-class detection rates (class_detection_rates.h): an object's p_real is its class's rate
  // among the map's other confirmed objects, with a prior of this many views at
  // existence_p_real, never below existence_p_real. <= 0: existence_p_real for every class (50).
  double existence_class_prior_views = 50;
  double confirm_llr = 2.0;
  double remove_llr = -4.0;
  VisibilityOptions visibility;
  // Flat-topped furniture (observation.mask.flat_top_classes and flat_top_margin_m, set by
  // Mapper from there): its geometry comes from its points up to its top surface, not from what
  // stands on it. Empty = none.
  std::vector<std::string> flat_top_classes;
  double flat_top_margin_m = 0.03;
  // Class size priors across classes (Mapper sets max_size_m from MapOptions::max_size_m): an
  // observation is not associated with an object of another class, and objects of other classes
  // do not merge, when either one is longer than class_size_slack x the other's class limit (a
  // 1.6 m desk is no "laptop", whatever a blurred view said). A fused box is the union of many
  // views, longer than one view's 5-95 % box. An object longer (oriented box) than this x its
  // own most likely class's limit is not confirmed (a fused 0.4 m "mouse"). <= 0 = off (1.5).
  std::map<std::string, double> max_size_m;
  double class_size_slack = 1.5;
  // Class shape priors (Mapper sets it from MapOptions::max_thickness_m): an object whose
  // oriented box is thicker than this along its thinnest side (its most likely class's value,
  // m) is not confirmed: a flat panel fused from views of the wall beside and behind it. Absent
  // = no limit.
  std::map<std::string, double> max_thickness_m;
  // Two objects of the same class whose axis-aligned boxes (map frame) overlap by more than this
  // share of the smaller box's volume are one object: two solid things do not interpenetrate.
  // Far objects (3 m and more: depth noise ~z^2, a degree of pose error moves them 5 cm) come back
  // as several smeared boxes whose voxels no longer overlap. Not flat-topped furniture: two desks
  // back to back that lie diagonally to the map's axes have boxes that hold each other; >= 1 =
  // off (0.75).
  double merge_box_containment = 0.75;
  // A part is no object of its own (object_parts.cc): an object whose voxels (overlap_voxel_m)
  // lie at least part_containment inside those that shape another object (FusedObject
  // ShapeKeysAt, not the few views that bled onto it) stays a candidate, with its evidence,
  // while they do (a monitor's stand called "mouse" on a few frames: fr1_rpy, session 27). The
  // other object is of another class, larger, seen at least as often, not flat-topped furniture
  // and not of a never_part_of class, which holds things on a seat or in a hand (a book on a
  // chair is not the chair's). A real thing beside or in front of another has its own surface.
  // > 1 = off (0.9).
  double part_containment = 0.9;
  std::vector<std::string> never_part_of = {"chair", "couch", "bed", "bench", "person"};
  // A stand is a part too (object_parts.cc): an object of another class whose centroid lies under
  // the middle of a stand_classes object (0.75 of its box's half depth and 0.35 of its half width
  // from its centre, below its centre and at most stand_height_m below its box). On fr1_rpy the
  // monitors' stands are called "mouse" on some views; their centroids sit within 0.10 of the
  // screen's half width from its middle, the cup beside the main monitor at 0.83-0.94 (15 runs,
  // session 39). Empty = off ([tv], 0.15).
  std::vector<std::string> stand_classes = {"tv"};
  double stand_height_m = 0.15;
  // Objects of the same class also merge when their centroids are closer than merge_sigmas
  // times the pair's position uncertainty, sqrt(2) s(r), where r is the distance of the nearer
  // object's nearest view (both must be far; a near object does not take in a far view's blob
  // beside it) and s(r)^2 = (depth_sigma_at_1m r^2)^2 + (view_sigma_rad r)^2:
  // depth noise grows with r^2 (Kinect-class sensors, 0.01 m at 1 m) and an orientation error
  // of the view moves the object by r times it (0.026 rad = 1.5 deg, the median orientation
  // error of loci-track's odometry on fr1_rpy after a rotation-only alignment). Near objects
  // keep merge_centroid_m (s(1 m) = 0.028 m); a thing seen only from 3 m and more by two robots
  // (or two passes) 15 cm apart is one thing. 0 = off (1.0).
  double merge_sigmas = 1.0;
  double depth_sigma_at_1m = 0.01;
  double view_sigma_rad = 0.026;
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
  // Reads `mapped` and `dynamic_classes` of config/classes.yaml.
  Status ClassesFromYaml(const YAML::Node& node);
  Status Validate() const;
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
inline constexpr int kMapCodeVersion = 16;

}  // namespace loci::server
