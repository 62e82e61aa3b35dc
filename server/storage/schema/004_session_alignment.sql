-- loci map database, schema version 4: robots that start anywhere. A session is aligned when
-- its odometry frame's placement in the base frame (map_t*, map_q*) is known: the map's first
-- session, a robot placed by config, or one place recognition has aligned. An unaligned
-- session's keyframes are stored but stay out of the map until it is aligned. Sessions stored
-- before this version were all mapped at their placement: they are aligned.
ALTER TABLE sessions ADD COLUMN aligned INTEGER NOT NULL DEFAULT 1;
