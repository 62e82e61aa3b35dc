-- loci map database, schema version 9: the object table becomes the published map. The map's
-- writer applies its changes about once a second (MapStore::Publish) instead of at checkpoints;
-- object_pb holds each whole object (loci.v1.Object) for read-only query servers.
ALTER TABLE objects ADD COLUMN object_pb BLOB NOT NULL DEFAULT x'';
-- Every robot's latest camera pose in the map frame (m; quaternion w x y z).
CREATE TABLE IF NOT EXISTS robot_poses (
  robot TEXT PRIMARY KEY,
  t_ns  INTEGER NOT NULL,
  tx REAL NOT NULL, ty REAL NOT NULL, tz REAL NOT NULL,
  qw REAL NOT NULL, qx REAL NOT NULL, qy REAL NOT NULL, qz REAL NOT NULL
);
-- One row: the publication count and the state a question needs besides the objects.
CREATE TABLE IF NOT EXISTS map_state (
  id               INTEGER PRIMARY KEY CHECK (id = 1),
  version          INTEGER NOT NULL,
  published_ns     INTEGER NOT NULL,
  last_keyframe_id INTEGER NOT NULL,
  up_x REAL, up_y REAL, up_z REAL,      -- the clients' gravity up; NULL when none sent it
  levelled_by      TEXT NOT NULL        -- how the map frame was levelled; '' = not levelled
);
