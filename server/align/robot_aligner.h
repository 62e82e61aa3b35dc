// Robots that start anywhere: finds where an unaligned session's odometry
// frame sits in the shared map from place recognition (server/place), and says so once enough
// verified matches agree.
//
// Per keyframe (AddKeyframe, one thread): ORB features from its images, a bag of words in the
// incremental vocabulary, then for a keyframe of an unaligned session a query over the
// keyframes of aligned sessions, geometric verification of the best candidates, and one
// estimate of T_base_odom per verified match,
//   T_base_odom(S) = T_base_kf(a) * T_a_b * T_odom_kf(b)^-1,
// given to a ConsistencyGate. When it accepts (3 agreeing keyframes by default), the estimate
// is levelled with both sides' gravity when both have it (only x, y, z and yaw come from the
// images), the session counts as aligned, and AddKeyframe returns the alignment. Every keyframe
// is then indexed, so later sessions can align against it too. An aligned session's later
// keyframes keep being matched until refine_max_matches agreeing matches are in; each time they
// double, AddKeyframe returns a refined placement (their mean, levelled).
//
// Unaligned sessions also form map islands: a keyframe of an unaligned session is matched
// against its own island's older keyframes (with loops: the island's loop closure, by its own
// max_verify budget) and the keyframes of unaligned sessions in other islands too, and when min_matches of
// them agree (ConsistencyGate, hypothesis per pair of islands), the querying session's island
// joins the other: each of its sessions gets T_island_odom in the other island's frame
// (levelled with gravity as a merge is). When any session of an island is aligned to the
// shared map, every session of the island is, through its T_island_odom.
// The bag-of-words index lives in memory; each keyframe's features go to a FeatureStore (the
// map database on the server) and only the most recently used stay in memory
// (place/feature_cache.h). After a restart the server rebuilds the index from the stored
// features, or the stored images where there are none (MapServer's re-indexing thread), while
// new keyframes are indexed as they come.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "common/camera.h"
#include "common/se3.h"
#include "server/align/align_options.h"
#include "server/place/consistency_gate.h"
#include "server/place/dense_refinement.h"
#include "server/place/feature_cache.h"
#include "server/place/keyframe_features.h"
#include "server/place/place_database.h"
#include "server/place/place_options.h"

namespace loci::server {

struct AlignKeyframe {
  int64_t keyframe_id = 0;
  int64_t session_row = 0;
  int64_t t_ns = 0;                      // capture time
  SE3d T_odom_kf = SE3d::Identity();     // the pose the robot sent
  std::optional<Vec3d> gravity_cam;      // unit, pointing down, when the robot sent it
};

struct SessionAlignment {
  int64_t session_row = 0;
  SE3d T_base_odom = SE3d::Identity();
  int64_t keyframe_id = 0;  // the keyframe whose match completed the consensus
  int matches = 0;          // verified matches that agreed
  bool levelled = false;    // roll and pitch from gravity
  bool refined = false;     // a better placement of a session aligned before
};

// How long a session waited to be aligned (by place recognition).
// A verified place-recognition match between two indexed keyframes (p_a = T_a_b * p_b): a loop
// (one session) or a merge (two sessions), for the pose graph (loop_closer.h).
struct VerifiedMatch {
  int64_t a_id = 0;  // the stored keyframe that was found
  int64_t b_id = 0;  // the querying keyframe
  SE3d T_a_b = SE3d::Identity();
  int inliers = 0;   // 3D-3D inliers
  double rms_m = 0;  // their RMS distance after alignment
  bool loop = false; // same session
};

// An island (all its sessions) placed in another unaligned session's island.
struct IslandJoin {
  int64_t from_island_row = 0;  // the island that moved (it no longer exists)
  int64_t island_row = 0;       // the island it joined
  // Every session that moved, with its odometry frame's placement in that island's frame.
  std::vector<std::pair<int64_t, SE3d>> T_island_odom;
  int64_t keyframe_id = 0;  // the keyframe whose match completed the consensus
};

// What one keyframe gave: an alignment of its session (and of the other sessions of its island,
// which follow it), an island join, and the verified matches.
struct AlignOutcome {
  std::optional<SessionAlignment> alignment;
  std::vector<SessionAlignment> island_alignments;
  std::optional<IslandJoin> join;
  std::vector<VerifiedMatch> matches;
};

struct AlignmentDelay {
  int keyframes = 0;         // the session's keyframes up to and including the aligning one
  double seconds = 0;        // capture time from its first keyframe to the aligning one
};

struct AlignStats {
  uint64_t keyframes = 0;         // keyframes indexed
  uint64_t queries = 0;           // keyframes of unaligned sessions queried
  uint64_t verified = 0;          // candidates that passed geometric verification
  uint64_t rejected = 0;          // candidates that did not
  uint64_t merges_accepted = 0;   // sessions aligned
  uint64_t refinements = 0;       // placements re-estimated from more matches
  uint64_t queries_ahead = 0;     // newest keyframes queried ahead of a backlog (QueryAhead)
  uint64_t merges_ahead = 0;      // ... that aligned their session (also in merges_accepted)
  uint64_t islands_pulled = 0;    // islands aligned by an aligned robot's keyframes (Pull)
  uint64_t merge_resets = 0;      // verified estimates that disagreed with the collected ones
  double place_ms_total = 0;      // features + words + query + verification, thread CPU ms
  uint64_t vocabulary_words = 0;
  uint64_t features_read = 0;     // candidates' features read back from the store (cache misses)
  uint64_t features_missing = 0;  // candidates skipped: their features could not be read
  uint64_t indexed_from_store = 0;  // keyframes indexed from stored features (IndexStored)
  // Verified matches whose relative pose the dense alignment refined, refused (no convergence
  // or a correction beyond place.dense's bounds: the sparse estimate kept), and could not refine
  // (the candidate's images neither in memory nor readable from the store: retention dropped
  // them, or no store was given).
  uint64_t dense_refined = 0;
  uint64_t dense_refused = 0;
  uint64_t dense_without_images = 0;
  uint64_t dense_frames_read = 0;  // candidates' images read back from the store (cache misses)
};

// T_to_from turned about pivot_to (a point in the `to` frame, kept where it is) so that the
// `from` side's down (its frame) maps onto the `to` side's down: only yaw and translation are
// left to the images. Either down zero: unchanged.
SE3d LevelOnto(const SE3d& T_to_from, const Vec3d& down_from, const Vec3d& down_to,
               const Vec3d& pivot_to);

// The shared map (its graph, its frame); map islands are keyed by their island's row (> 0).
inline constexpr int64_t kSharedGraph = 0;

class RobotAligner {
 public:
  // `features` keeps every keyframe's features (it outlives the aligner); null: in memory.
  // `images` gives back a keyframe's images when its reduced images have left the dense
  // refinement's cache (it outlives the aligner); null: such matches are not refined.
  RobotAligner(const place::PlaceOptions& place, const AlignOptions& options,
               place::FeatureStore* features = nullptr,
               place::KeyframeImageSource* images = nullptr);

  // Declares a session before its first keyframe: aligned at T_base_odom, or not (nullopt).
  // A session declared again keeps its state.
  void AddSession(int64_t session_row, std::optional<SE3d> T_base_odom);
  // The session's placement in the base frame, when aligned (nullopt: unaligned or unknown).
  std::optional<SE3d> Alignment(int64_t session_row) const;
  bool Known(int64_t session_row) const;
  // Whether any declared session is aligned.
  bool AnyAligned() const;
  // An unaligned session's island: the row of the island's first session (its own row when it
  // joined none) and where the session's odometry frame sits in that island's frame.
  std::pair<int64_t, SE3d> IslandOf(int64_t session_row) const;
  // Places an unaligned session in island_row (its own row: its own island) at T_island_odom:
  // a membership restored after a restart, or the placement an island's loop closure corrected.
  void SetIsland(int64_t session_row, int64_t island_row, const SE3d& T_island_odom);

  // See the file comment. `bgr` CV_8UC3 and `depth_m` CV_32FC1 (0 = no depth) of the keyframe;
  // an unknown session is an error, as are images the features cannot be read from.
  // With match = false the keyframe is only indexed (rebuilding the index after a restart).
  // Calls are serialised (the mapping worker and the re-indexing after a restart).
  // With options.loops.enabled, every keyframe of an aligned session is matched too (against
  // the older keyframes of its own session and the other aligned sessions), and the outcome
  // lists every verified match; placements are then not refined here (the pose graph does it).
  StatusOr<AlignOutcome> AddKeyframe(const AlignKeyframe& kf, const cv::Mat& bgr,
                                     const cv::Mat& depth_m, const PinholeCamera& camera,
                                     bool match = true);
  // Place recognition of an unaligned session's newest keyframe ahead of the keyframes waiting
  // before it for the mapping worker and AddKeyframe (a robot that streamed a backlog elsewhere
  // first): its features are matched against the aligned sessions' keyframes only, and the
  // estimate goes to the same consistency gate, but nothing is indexed or counted. AddKeyframe
  // later indexes it as usual; the gate ignores its second estimate (a keyframe counts once).
  // The outcome holds the verified matches (pose-graph merge edges once the keyframe is mapped;
  // AddKeyframe may find the same pairs again) and the alignment (and its island's) when this
  // keyframe completes the consensus. Empty for a keyframe already indexed or a session that is
  // aligned or not declared.
  StatusOr<AlignOutcome> QueryAhead(const AlignKeyframe& kf, const cv::Mat& bgr,
                                    const cv::Mat& depth_m, const PinholeCamera& camera);
  // Indexes a keyframe from features read back from the store (re-indexing after a restart):
  // AddKeyframe with match = false, without extracting or storing them again.
  Status IndexStored(const AlignKeyframe& kf, place::KeyframeFeatures features);
  // Places an aligned session anew (after a pose-graph solve moved its keyframes).
  void SetAlignment(int64_t session_row, const SE3d& T_base_odom);
  // Where keyframes are mapped now, in the frame of map_row's map (kSharedGraph, 0: the base
  // frame; else an island's row): a solve's corrected poses, or an island's carried into the
  // base or another island. A match to such a keyframe estimates the placement from this pose
  // instead of the keyframe's odometry x its session's placement, which a loop closure has left
  // behind. Used while the keyframe's session is in that map; any thread.
  void SetMappedPoses(int64_t map_row, const std::vector<std::pair<int64_t, SE3d>>& T_map_kf);
  bool Indexed(int64_t keyframe_id) const;
  // For a session aligned by place recognition since the start: how long it waited.
  std::optional<AlignmentDelay> Delay(int64_t session_row) const;
  AlignStats Stats() const;  // any thread

 private:
  struct Session {
    std::optional<SE3d> T_base_odom;
    Vec3d gravity_sum_odom = Vec3d::Zero();  // sum of unit gravity vectors in the odom frame
    int gravity_count = 0;
    // Aligned by place recognition (not the origin or a configured placement): refined.
    bool recognised = false;
    std::vector<SE3d> estimates;  // agreeing estimates of T_base_odom since the alignment
    size_t next_refine = 0;       // refine when estimates reach this many (0 = done)
    int keyframes = 0;            // seen by AddKeyframe
    int64_t first_t_ns = 0;
    int64_t last_t_ns = 0;
    // Aligned by a keyframe queried ahead (not counted yet): the delay is set when it is.
    int64_t delay_keyframe_id = 0;
    std::optional<AlignmentDelay> delay;
    int64_t island_row = 0;  // unaligned: the island joined (0 = its own)
    SE3d T_island_odom = SE3d::Identity();
  };
  struct IndexedKeyframe {  // the features are in cache_
    int64_t session_row = 0;
    int64_t t_ns = 0;
    SE3d T_odom_kf = SE3d::Identity();
  };
  // A query keyframe's features, its bag of words (new words go into the vocabulary with
  // add_words) and, with `dense` and place.dense on, its reduced images.
  struct Described {
    place::KeyframeFeatures features;
    place::BowVector bow;
    std::shared_ptr<const place::DenseFrame> dense;
  };
  StatusOr<Described> Describe(const cv::Mat& bgr, const cv::Mat& depth_m,
                               const PinholeCamera& camera, bool add_words, bool dense);
  // Counts the keyframe into its session (an error when it is not declared); whether the
  // session is aligned.
  StatusOr<bool> CountIn(const AlignKeyframe& kf);
  // Quantises and indexes the keyframe (its features are stored or kept by the caller).
  Status Index(const AlignKeyframe& kf, const place::BowVector& bow);
  // Counts an indexed keyframe and its CPU time since t0_ms (stats_mu_ and work_mu_ held).
  void CountIndexed(double t0_ms);
  // Verifies the best candidates (max_verify, in rank order) among the keyframes of aligned
  // sessions and, with loops, the older ones of kf's own session; every match that verifies.
  // An unaligned query also verifies candidates of unaligned sessions in other islands, unless
  // aligned_only; an aligned query with loops, those of every island (Pull). `dense`: the
  // query's reduced images (null: no dense refinement).
  std::vector<VerifiedMatch> Match(const AlignKeyframe& kf, const place::KeyframeFeatures& features,
                                   const place::BowVector& bow, bool loops, bool query_aligned,
                                   const place::DenseFrame* dense, bool aligned_only = false);
  // T_a_b refined by the dense alignment when it can be (b null: not tried); counts the outcome.
  SE3d RefinedDense(int64_t a_id, const place::DenseFrame* b, const SE3d& T_a_b);
  // Keyframe a_id's reduced images: from the cache, else read back through images_ and cached;
  // null when neither has them.
  std::shared_ptr<const place::DenseFrame> DenseFrameOf(int64_t a_id);
  // Keyframe a's pose in the frame of map_row's map: the one SetMappedPoses gave while in that
  // map, else T_map_odom (its session's placement there) x its odometry.
  SE3d MappedPose(int64_t a_id, const IndexedKeyframe& a, int64_t map_row,
                  const SE3d& T_map_odom) const;
  // IslandOf with sessions_mu_ held.
  std::pair<int64_t, SE3d> IslandOfLocked(int64_t session_row) const;
  // Whether two sessions are one unaligned island (sessions_mu_ not held).
  bool SameIsland(int64_t a_row, int64_t b_row) const;
  // The best-ranked match to another island, through the gate; the join when it accepts.
  std::optional<IslandJoin> Join(const AlignKeyframe& kf, const std::vector<VerifiedMatch>& matches);
  // After `aligned` placed its session: the other sessions of its island, placed through it.
  std::vector<SessionAlignment> AlignIsland(const SessionAlignment& aligned);
  // The estimates of T_base_odom(kf's session), one per merge match.
  std::vector<SE3d> Estimates(const AlignKeyframe& kf, const std::vector<VerifiedMatch>& matches) const;
  // `counted`: kf went through CountIn (not a keyframe queried ahead).
  std::optional<SessionAlignment> Gate(const AlignKeyframe& kf, const std::vector<SE3d>& estimates,
                                       bool counted = true);
  // For an aligned session: keeps the estimates that agree with its placement; a refined
  // placement when their count reached the next refinement.
  std::optional<SessionAlignment> Refine(const AlignKeyframe& kf,
                                         const std::vector<SE3d>& estimates);
  bool Refining(int64_t session_row) const;
  // Replaces the roll and pitch of T_base_odom with those gravity gives, keeping the matched
  // keyframe's position; false when either side lacks gravity.
  bool Level(const Session& session, const Vec3d& pivot_odom, SE3d* T_base_odom) const;
  // The sum of the gravity (unit vectors, pointing down) of an island's sessions in its frame,
  // and how many keyframes it sums (sessions_mu_ held).
  std::pair<Vec3d, int> IslandDown(int64_t island_row) const;
  // The sum of the aligned sessions' gravity in the base frame, and its count (sessions_mu_
  // held).
  std::pair<Vec3d, int> BaseDown() const;
  // An aligned keyframe's verified matches to keyframes of unaligned islands: each estimates
  // where its island's frame sits in the base frame (hypothesis per island in the gate). When 3
  // keyframes agree, every session of the island is aligned (levelled with both sides' gravity
  // as a merge is): an island whose robot has stopped streaming still enters the shared map
  // when an aligned robot sees its places.
  std::vector<SessionAlignment> Pull(const AlignKeyframe& kf,
                                     const std::vector<VerifiedMatch>& matches);
  static std::string Key(int64_t session_row);

  place::PlaceOptions place_;
  AlignOptions options_;
  mutable std::mutex work_mu_;  // db_, gate_, indexed_, cache_, dense_cache_, dense_refiner_
  std::unique_ptr<place::MemoryFeatureStore> own_features_;  // when none was given
  place::FeatureCache cache_;
  place::DenseFrameCache dense_cache_;
  place::DenseRefiner dense_refiner_;
  place::KeyframeImageSource* images_;  // may be null
  place::PlaceDatabase db_;
  place::ConsistencyGate gate_;
  std::map<int64_t, Session> sessions_;
  std::map<int64_t, IndexedKeyframe> indexed_;  // by keyframe id
  mutable std::mutex stats_mu_;
  AlignStats stats_;
  mutable std::mutex mapped_mu_;  // mapped_
  struct MappedPoseOf {
    int64_t map_row = 0;
    SE3d T_map_kf = SE3d::Identity();
  };
  std::unordered_map<int64_t, MappedPoseOf> mapped_;  // by keyframe id (SetMappedPoses)
  mutable std::mutex sessions_mu_;  // sessions_ (Alignment / Known from other threads)
};

}  // namespace loci::server
