-- loci map database, schema version 2: per-keyframe map products and checkpoints of the
-- derived map (server/map/product_codec.h, map_checkpoint.cc; loci.store.v1 messages).
-- Products are in the keyframe frame and are a pure function of the keyframe and the map
-- options; the map is derived from them and the keyframe poses, so the raw images may go
-- (retention) once a keyframe's products exist.
CREATE TABLE IF NOT EXISTS keyframe_products (
  keyframe_id INTEGER PRIMARY KEY REFERENCES keyframes(id),
  fingerprint TEXT NOT NULL,       -- MapOptions::ProductsFingerprint they were made with
  data        BLOB NOT NULL,       -- loci.store.v1.KeyframeProducts
  stored_ns   INTEGER NOT NULL
);

CREATE TABLE IF NOT EXISTS checkpoints (
  id               INTEGER PRIMARY KEY AUTOINCREMENT,
  last_keyframe_id INTEGER NOT NULL,  -- every keyframe up to this id is in the checkpoint
  data             BLOB NOT NULL,     -- loci.store.v1.MapperCheckpoint
  stored_ns        INTEGER NOT NULL
);
