-- loci map database, schema version 1.
-- Source of truth: sessions and every acknowledged keyframe (compressed images, pose in the
-- session's odometry frame, detections). Map products (objects, cloud, OctoMap) are derived by
-- replaying keyframes, so a pose correction never edits stored world coordinates.
CREATE TABLE IF NOT EXISTS meta (
  key   TEXT PRIMARY KEY,
  value TEXT NOT NULL
);

CREATE TABLE IF NOT EXISTS sessions (
  id             INTEGER PRIMARY KEY AUTOINCREMENT,
  session_id     TEXT NOT NULL UNIQUE,      -- public id handed to the client
  robot_name     TEXT NOT NULL,
  client_version TEXT NOT NULL DEFAULT '',
  fx REAL NOT NULL, fy REAL NOT NULL, cx REAL NOT NULL, cy REAL NOT NULL,
  width_px INTEGER NOT NULL, height_px INTEGER NOT NULL,
  depth_scale    REAL NOT NULL,             -- depth PNG units per metre
  -- T_map_odom of this session: translation (m) + unit quaternion (w, x, y, z).
  map_tx REAL NOT NULL DEFAULT 0, map_ty REAL NOT NULL DEFAULT 0, map_tz REAL NOT NULL DEFAULT 0,
  map_qw REAL NOT NULL DEFAULT 1, map_qx REAL NOT NULL DEFAULT 0, map_qy REAL NOT NULL DEFAULT 0,
  map_qz REAL NOT NULL DEFAULT 0,
  opened_ns      INTEGER NOT NULL,
  closed_ns      INTEGER                    -- NULL while open
);
CREATE INDEX IF NOT EXISTS sessions_robot ON sessions(robot_name, id);

CREATE TABLE IF NOT EXISTS keyframes (
  id          INTEGER PRIMARY KEY AUTOINCREMENT,   -- server keyframe id, replay order
  session     INTEGER NOT NULL REFERENCES sessions(id),
  seq         INTEGER NOT NULL,                    -- client sequence number
  t_ns        INTEGER NOT NULL,
  -- T_odom_cam: translation (m) + unit quaternion (w, x, y, z).
  tx REAL NOT NULL, ty REAL NOT NULL, tz REAL NOT NULL,
  qw REAL NOT NULL, qx REAL NOT NULL, qy REAL NOT NULL, qz REAL NOT NULL,
  fx REAL NOT NULL, fy REAL NOT NULL, cx REAL NOT NULL, cy REAL NOT NULL,
  width_px INTEGER NOT NULL, height_px INTEGER NOT NULL,
  depth_scale REAL NOT NULL,
  has_gravity INTEGER NOT NULL DEFAULT 0,
  gx REAL NOT NULL DEFAULT 0, gy REAL NOT NULL DEFAULT 0, gz REAL NOT NULL DEFAULT 0,
  segment     INTEGER NOT NULL DEFAULT 0,
  rgb_jpeg    BLOB NOT NULL,
  depth_png   BLOB NOT NULL,
  detections  TEXT NOT NULL,                       -- one detections.jsonl line (docs/formats.md)
  stored_ns   INTEGER NOT NULL,
  UNIQUE(session, seq)
);
