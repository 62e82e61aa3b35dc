-- loci map database, schema version 6: each keyframe's place-recognition features
-- (server/place/feature_codec.h, "LPF1"), written once by the aligning thread, so they need not
-- stay in memory and survive a restart and the retention of raw images. `fingerprint` names the
-- feature options they were extracted with (FeatureOptions::Fingerprint); features of another
-- fingerprint are extracted again from the images.
CREATE TABLE IF NOT EXISTS place_features (
  keyframe_id INTEGER PRIMARY KEY REFERENCES keyframes(id),
  fingerprint TEXT NOT NULL,
  data BLOB NOT NULL
);
