-- loci map database, schema version 7: map islands that join. An unaligned session whose
-- odometry frame place recognition has placed in another unaligned session's island stores that
-- island's session row here, and its placement in the island's frame (T_island_odom) in map_t*,
-- map_q* (which hold T_base_odom once it is aligned). NULL: the session is its own island.
ALTER TABLE sessions ADD COLUMN island_row INTEGER;
