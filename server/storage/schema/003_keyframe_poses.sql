-- loci map database, schema version 3: corrected keyframe poses. A pose update (loop closure,
-- robot alignment) stores T_base_kf here; it replaces session.T_base_odom * T_odom_cam for that
-- keyframe on every later load, reprocess and re-derivation. The acknowledged odometry pose in
-- `keyframes` stays as the robot sent it.
CREATE TABLE IF NOT EXISTS keyframe_poses (
  keyframe_id INTEGER PRIMARY KEY REFERENCES keyframes(id),
  tx REAL NOT NULL, ty REAL NOT NULL, tz REAL NOT NULL,                  -- T_base_kf, m
  qw REAL NOT NULL, qx REAL NOT NULL, qy REAL NOT NULL, qz REAL NOT NULL,
  updated_ns INTEGER NOT NULL
);
