-- loci map database, schema version 8: the object table, for tools that read the map with SQL.
-- Each checkpoint replaces it with the shared map's objects in the same transaction (map frame,
-- m; the box is axis-aligned); the map itself is derived from the keyframes, never from here.
CREATE TABLE IF NOT EXISTS objects (
  id                INTEGER PRIMARY KEY,   -- the map's object id
  class_name        TEXT NOT NULL,
  confidence        REAL NOT NULL,
  confirmed         INTEGER NOT NULL,
  cx REAL NOT NULL, cy REAL NOT NULL, cz REAL NOT NULL,
  min_x REAL NOT NULL, min_y REAL NOT NULL, min_z REAL NOT NULL,
  max_x REAL NOT NULL, max_y REAL NOT NULL, max_z REAL NOT NULL,
  observation_count INTEGER NOT NULL,
  last_seen_ns      INTEGER NOT NULL,
  removed_t_ns      INTEGER NOT NULL        -- 0: in the map
);
