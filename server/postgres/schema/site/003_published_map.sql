-- loci site map, schema version 3: the object table becomes the published map. The site's
-- writer applies its changes about once a second (MapStore::Publish) instead of at checkpoints
-- and notifies channel loci_map with the site's name, so read-only query servers that LISTEN
-- reload at once; object_pb holds each whole object (loci.v1.Object) for them.
ALTER TABLE objects ADD COLUMN object_pb BYTEA NOT NULL DEFAULT '';
-- Every robot's latest camera pose in the map frame (m; quaternion w x y z); `position` is its
-- point with an n-D GiST index.
CREATE TABLE robot_poses (
  robot    TEXT PRIMARY KEY,
  t_ns     BIGINT NOT NULL,
  tx DOUBLE PRECISION NOT NULL, ty DOUBLE PRECISION NOT NULL, tz DOUBLE PRECISION NOT NULL,
  qw DOUBLE PRECISION NOT NULL, qx DOUBLE PRECISION NOT NULL, qy DOUBLE PRECISION NOT NULL,
  qz DOUBLE PRECISION NOT NULL,
  position geometry(PointZ, 0) NOT NULL
);
CREATE INDEX robot_poses_position ON robot_poses USING GIST (position gist_geometry_ops_nd);
-- One row: the publication count and the state a question needs besides the objects.
CREATE TABLE map_state (
  id               INT PRIMARY KEY CHECK (id = 1),
  version          BIGINT NOT NULL,
  published_ns     BIGINT NOT NULL,
  last_keyframe_id BIGINT NOT NULL,
  up_x DOUBLE PRECISION, up_y DOUBLE PRECISION, up_z DOUBLE PRECISION,  -- NULL: no gravity
  levelled_by      TEXT NOT NULL          -- how the map frame was levelled; '' = not levelled
);
