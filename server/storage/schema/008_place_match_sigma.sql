-- loci map database, schema version 8: each verified place match keeps its estimate's rotation
-- standard deviation along its weakest direction (rad; 0 = unknown, stored before version 8), so
-- that a restart weighs its graph edge as before (align.loops.fit_sigma_scale).
ALTER TABLE place_matches ADD COLUMN rotation_sigma_rad REAL NOT NULL DEFAULT 0;
