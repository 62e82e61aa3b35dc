// Options of place recognition and geometric verification: the `place` section of
// config/server.yaml. Every field documents its unit and default; FromYaml reads only the keys
// present and checks for unknown ones (common/config.h).
#pragma once

#include <string>

#include <yaml-cpp/yaml.h>

#include "common/status.h"

namespace loci::place {

// ORB features of a keyframe, extracted on the server from its JPEG and depth PNG.
struct FeatureOptions {
  int max_features = 1000;    // ORB keypoints kept per keyframe, best FAST/Harris response (1000)
  double scale_factor = 1.2;  // image pyramid ratio between levels (1.2)
  int levels = 8;             // pyramid levels (8)
  int fast_threshold = 20;    // FAST corner threshold, grey levels (20)
  // Keypoints whose depth lies outside [min_depth_m, max_depth_m] get no 3D point; they still
  // count for the bag of words (0.1, 4.0 m: Kinect-class depth noise grows with z^2).
  double min_depth_m = 0.1;
  double max_depth_m = 4.0;
  // Keyframes whose features stay in memory; the others' are read back from the map database
  // when verification needs them (feature_cache.h; about 60 KB each) (256).
  int cache_keyframes = 256;

  // Names the options that change extracted features (not cache_keyframes): stored features of
  // another fingerprint are extracted again.
  std::string Fingerprint() const;
};

// The incremental vocabulary (incremental_vocabulary.h).
struct VocabularyOptions {
  // A descriptor belongs to its nearest word when they differ in at most this many of the 256
  // bits; otherwise it founds a new word (60).
  int word_max_hamming = 60;
  int branching = 16;        // children made when a leaf of the word tree splits, k (16)
  int max_leaf_words = 256;  // a leaf holding more words is split by k-majority clustering (256)
  int max_depth = 16;        // leaves at this depth are no longer split (16)
  // Leaves a search visits, nearest centres first: more finds more words again across cluster
  // borders, at a proportional cost (4; at most kMaxSearchLeaves).
  int search_leaves = 4;
};
inline constexpr int kMaxSearchLeaves = 256;

// Candidate retrieval (place_database.h).
struct QueryOptions {
  int max_candidates = 5;  // candidates returned, best score first (5)
  // The querying robot's own newest N keyframes are never candidates (they are its odometry
  // neighbours, not a loop) (10). Keyframes are made by view change, so N counts views, not time.
  int exclude_recent_keyframes = 10;
  // Candidates need at least this normalised score (the query's tf-idf mass shared with the
  // candidate, 0..1) (0.02).
  double min_score = 0.02;
  // Besides, the best N of the querying robot's own keyframes older than its newest
  // older_than_keyframes, when they are not among the max_candidates already; they follow the
  // best candidate. The nearest views score highest, so without them every loop joins views
  // inside a client's local map (loci-track: 30 keyframes), whose odometry holds no drift worth
  // correcting (1, 30; 0: off).
  int older_candidates = 1;
  int older_than_keyframes = 30;
};

// Geometric verification of a candidate pair (geometric_verification.h).
struct VerifyOptions {
  double ratio = 0.8;    // Lowe ratio test on Hamming distances: best < ratio * second best
  int max_hamming = 64;  // matches differing in more bits are dropped (64 of 256)
  double pnp_reprojection_px = 3.0;  // PnP-RANSAC inlier threshold, px (3.0)
  int pnp_iterations = 300;          // PnP-RANSAC iterations (300)
  double pnp_confidence = 0.999;     // PnP-RANSAC confidence (0.999)
  // 3D-3D check: a PnP inlier with depth in both keyframes is a 3D inlier when the points
  // agree within this distance after alignment, m (0.05).
  double max_point_error_m = 0.05;
  int min_inliers = 30;  // PnP and 3D-3D inliers a match needs (30)
  // Noise model of the final estimate (point_alignment.h): keypoint position noise at level 0
  // (1.0 px, grows with the pyramid level) and depth noise sigma_z = this * z^2 (0.0025 m/m^2;
  // Kinect-class sensors: about 1.5-3 mm at 1 m).
  double pixel_sigma_px = 1.0;
  double depth_sigma_m_per_m2 = 0.0025;
  double max_rms_m = 0.03;  // RMS distance of the 3D inliers after alignment, m (0.03)
  // The box of the middle 90% of the 3D inliers' pixels must cover at least this share of the
  // image: matches on one small patch (a poster, a repeated texture) are refused (0.02).
  double min_inlier_area = 0.02;
};

// Acceptance of a loop or merge hypothesis (consistency_gate.h).
struct ConsistencyOptions {
  // Verified matches from this many distinct keyframes must agree on the relative transform
  // before the hypothesis is accepted (3; ORB-SLAM3's Atlas confirms merges on 3 keyframes).
  int min_matches = 3;
  double max_translation_m = 0.10;  // agreement: translations differ by at most this, m (0.10)
  double max_rotation_deg = 3.0;    // ... and rotations by at most this angle, deg (3.0)
};

// Dense refinement of verified matches (dense_refinement.h).
struct DenseOptions {
  bool enabled = true;
  double scale = 0.5;  // the images are resized by this before the alignment (0.5: 320 x 240)
  int levels = 3;      // image pyramid levels of the coarse-to-fine solver, 1..4 (3)
  // Pixels with depth outside [min_depth_m, max_depth_m] are left out (0.1, 4.0 m).
  double min_depth_m = 0.1;
  double max_depth_m = 4.0;
  // ICP correspondences whose depths differ by more than this are dropped, m (0.07).
  double max_depth_diff_m = 0.07;
  // A refinement that moves the sparse estimate further than this is refused and the sparse
  // estimate kept: the dense solver's basin is a few centimetres and degrees (0.10 m, 0.07 rad).
  double max_correction_m = 0.10;
  double max_correction_rad = 0.07;
  // Verified matches refined per keyframe, best-ranked first; the others keep their sparse
  // estimate (each costs about 17 ms of CPU at scale 0.5; 8 robots on 2 cores afford 1) (1).
  int max_per_keyframe = 1;
  // Keyframes whose reduced images stay in memory (about 0.4 MB each at scale 0.5); a
  // candidate outside them is read back from the database's images (about 7 ms of CPU), or,
  // where retention dropped them, not refined (256).
  int cache_keyframes = 256;
};

struct PlaceOptions {
  FeatureOptions features;
  VocabularyOptions vocabulary;
  QueryOptions query;
  VerifyOptions verify;
  ConsistencyOptions consistency;
  DenseOptions dense;

  // Reads the subsections features / vocabulary / query / verify / consistency of `place`.
  Status FromYaml(const YAML::Node& node);
  Status Validate() const;
};

}  // namespace loci::place
