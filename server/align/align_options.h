// Options of robot alignment (section `align` of config/server.yaml; robot_aligner.h).
#pragma once

#include <yaml-cpp/yaml.h>

#include "common/status.h"

namespace loci::server {

// Loop closure and the pose graph on the server (section `align.loops`; loop_closer.h).
struct LoopOptions {
  // Every keyframe of an aligned session is also matched against the older keyframes of its
  // own session (loops) and the other aligned sessions (merges); verified matches become pose
  // graph edges, and the graph (section `graph`) is solved and the map moved to its solution
  // (true). false: no loop closure; a merged session's placement is refined from its later
  // matches instead (refine_max_matches).
  bool enabled = true;
  // A loop joins keyframes captured at least this far apart, s (2.0): nearer ones are odometry
  // neighbours (place.query.exclude_recent_keyframes also applies). A camera that turns fast
  // sees its first views again within seconds; a loop to them is what corrects the odometry's
  // early drift (on a real TUM sequence: the first keyframe, 3.6 deg off the rest, is reached
  // from 2.7 s on).
  double min_gap_s = 2.0;
  // Standard deviations of a verified match as a graph edge: translation (m) and rotation (rad)
  // (0.02, 0.01). The wrong-loop guard (graph.pcm) works in these units.
  double sigma_trans_m = 0.02;
  double sigma_rot_rad = 0.01;
  // The graph is solved once this many new verified edges (loops or merges between mapped
  // keyframes) are in (3) ...
  int optimize_every_edges = 3;
  // ... and at least this many keyframes were mapped since the last solve (10).
  int optimize_min_keyframes = 10;
  // ... and at least this share of the keyframes already in the graph (0.05): a solve rebuilds
  // the whole graph, so spacing solves in proportion to its size keeps the cost per keyframe
  // flat (1000 keyframes: a solve every 50, not every 10).
  double optimize_growth = 0.05;
  // The solution moves the map this many keyframes per hold of the mapping lock, newest first
  // (256; 0 = all at once): the mapping worker waits for one chunk at most (0.2-1.5 ms per
  // keyframe moved), not for the whole move (seconds at 10k keyframes). Keyframes the worker maps
  // between chunks meet a partly moved map, which can change associations (on a real sequence,
  // 64 fused a book into its neighbour); 256 keeps moves of a few hundred keyframes in one hold.
  int apply_chunk_keyframes = 256;
  // An unaligned robot's keyframe verifies at most this many candidates of its own island (its
  // island's loop closure), besides the max_verify others where it may be aligned or joined (1;
  // 0 = islands close no loops). Each costs a verification (about 10 ms): a robot revisiting its
  // own places on every keyframe paid 3 per keyframe at 3 (`loci bench merge --held 1000`:
  // place recognition 41 ms per keyframe, against 9 without island loops).
  int island_max_verify = 1;

  int64_t min_gap_ns() const { return static_cast<int64_t>(min_gap_s * 1e9); }
  Status FromYaml(const YAML::Node& node);
  Status Validate() const;
};

struct AlignOptions {
  // A new session of a robot that config/server.yaml's `sessions.T_base_odom` does not place
  // starts unaligned when the map already has an aligned session: its keyframes are stored, and
  // their products made, but they stay out of the shared map until place recognition finds
  // where the robot is (true). false: every session is placed at its configured T_base_odom or
  // the identity, as if all robots started at the first robot's start.
  bool enabled = true;
  // Place-recognition candidates geometrically verified per keyframe (3).
  int max_verify = 3;
  // When both robots send gravity, the merge's roll and pitch come from gravity, not from the
  // matched images: only x, y, z and yaw are estimated, so a merge cannot tilt the map (true).
  bool level_with_gravity = true;
  // Keyframes with gravity a session needs before its gravity is trusted for levelling (1: the
  // levelled estimate is refined with more keyframes' gravity as matches accumulate).
  int min_gravity_keyframes = 1;
  // After a session is aligned its later keyframes keep being matched against the other aligned
  // sessions; each time the agreeing matches double (6, 12, 24, ...) the placement is
  // re-estimated from all of them and the session's keyframes move to it, until this many
  // matches are in (48; 0 = no refinement). One match's error grows with the camera's speed
  // (measured): the mean of many is steadier than that of the first three.
  int refine_max_matches = 48;
  // When a robot is aligned, the keyframes the server held back enter the map this many per
  // hold of the mapping lock (8; 0 = all at once). Each is mapped from its stored products, about
  // 10 ms (measured): the mapping worker, and through it every robot's stream, waits for
  // one chunk, not for all of them (about 10 s for 1000 held keyframes).
  int held_chunk_keyframes = 8;
  // An unaligned robot's island map has an OctoMap of its own, in the island's frame (true; a
  // thread and a tree per island, and ray casting, about 20 ms per keyframe, that the shared
  // map does again once the robot is aligned). false: islands have objects and a cloud only.
  bool island_octomap = true;
  // When at least this many keyframes wait to be mapped or recognised (both queues), an
  // unaligned robot's newest keyframe is matched against the shared map ahead of them
  // (RobotAligner::QueryAhead), so that a robot that streamed a backlog elsewhere is aligned
  // within about its next three keyframes instead of after the backlog (16; 0 = off). Below
  // it every keyframe goes through place recognition once, in order: a burst (a robot's first
  // 20 keyframes sent at once) is worked through in order as fast, and the newest keyframe
  // would only complete a consensus its first ones were about to. Both queues hold up to
  // 2 x server.queue_capacity keyframes, so keep it below that.
  int query_ahead_backlog = 16;
  LoopOptions loops;

  // Reads the keys of `align`; unknown keys are errors.
  Status FromYaml(const YAML::Node& node);
  Status Validate() const;
};

}  // namespace loci::server
