-- loci map database, schema version 5: verified place-recognition matches (loop closure and
-- robot merges, server/align/). Each row is one geometrically verified match between two stored
-- keyframes, p_a = T_a_b * p_b in their camera frames; the pose graph is rebuilt from these and
-- the keyframes' odometry after a restart. A match is a measurement, never updated. Keyframes
-- gain the client's tracking quality (inliers of its pose estimate; 0 = unknown), which weighs
-- the odometry edges of the graph.
CREATE TABLE IF NOT EXISTS place_matches (
  a_keyframe_id INTEGER NOT NULL REFERENCES keyframes(id),
  b_keyframe_id INTEGER NOT NULL REFERENCES keyframes(id),
  tx REAL NOT NULL, ty REAL NOT NULL, tz REAL NOT NULL,                  -- T_a_b, m
  qw REAL NOT NULL, qx REAL NOT NULL, qy REAL NOT NULL, qz REAL NOT NULL,
  inliers INTEGER NOT NULL,
  rms_m REAL NOT NULL,
  found_ns INTEGER NOT NULL,
  PRIMARY KEY (a_keyframe_id, b_keyframe_id)
);
ALTER TABLE keyframes ADD COLUMN tracking_inliers INTEGER NOT NULL DEFAULT 0;
