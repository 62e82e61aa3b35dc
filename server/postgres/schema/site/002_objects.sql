-- loci site map, schema version 2: the object table, for tools that read the map with SQL.
-- Each checkpoint replaces it with the shared map's objects in the same transaction; the map is
-- derived from the keyframes, never from here. `box` is the axis-aligned box as a PostGIS 3D
-- polyhedral surface and `centroid` a point (SRID 0, the map frame, m), both with n-D GiST
-- indexes: `WHERE box &&& ST_3DMakeBox(ST_MakePoint(x0, y0, z0), ST_MakePoint(x1, y1, z1))`
-- finds the objects whose boxes meet a query box.
CREATE TABLE objects (
  id                BIGINT PRIMARY KEY,   -- the map's object id
  class_name        TEXT NOT NULL,
  confidence        DOUBLE PRECISION NOT NULL,
  confirmed         BOOLEAN NOT NULL,
  centroid          geometry(PointZ, 0) NOT NULL,
  box               geometry NOT NULL,    -- a 3D polyhedral surface (a point or polygon when flat)
  observation_count BIGINT NOT NULL,
  last_seen_ns      BIGINT NOT NULL,
  removed_t_ns      BIGINT NOT NULL         -- 0: in the map
);
CREATE INDEX objects_box ON objects USING GIST (box gist_geometry_ops_nd);
CREATE INDEX objects_centroid ON objects USING GIST (centroid gist_geometry_ops_nd);
CREATE INDEX objects_class ON objects (class_name);
