-- loci fleet tables, version 1, in the database's public schema, shared by every site.
-- A site is one map (a building); its tables live in the schema site_<name> (site/*.sql).
-- One server maps a site at a time: it holds the site's lease row until expires_at, renews it
-- well before then, and bumps `epoch` when it takes the lease over. Every write transaction of
-- the site checks the epoch (a fencing token), so a writer that lost its lease (paused,
-- partitioned) can no longer write after another server took over.
CREATE EXTENSION IF NOT EXISTS postgis;

CREATE TABLE IF NOT EXISTS loci_sites (
  site        TEXT PRIMARY KEY,
  schema_name TEXT NOT NULL UNIQUE,
  created_ns  BIGINT NOT NULL
);

CREATE TABLE IF NOT EXISTS loci_site_leases (
  site       TEXT PRIMARY KEY REFERENCES loci_sites(site),
  holder     TEXT NOT NULL,              -- the writer's id (host, pid, random part)
  address    TEXT NOT NULL DEFAULT '',   -- where robots reach the writer (gRPC host:port)
  epoch      BIGINT NOT NULL,            -- bumped on every takeover
  expires_at TIMESTAMPTZ NOT NULL
);
