// Options of `loci-server` (config/server.yaml documents every key).
#pragma once

#include <yaml-cpp/yaml.h>

#include <map>
#include <string>

#include "common/se3.h"
#include "common/status.h"
#include "server/map/map_options.h"
#include "server/align/align_options.h"
#include "server/graph/graph_options.h"
#include "server/place/place_options.h"

namespace loci::server {

struct ServerOptions {
  std::string listen = "127.0.0.1:50051";  // gRPC address, HOST:PORT (port 0 = any free port)
  std::string db_path = "loci.db";         // SQLite database file
  // Where the map is stored: "" = SQLite at db_path; "sqlite:FILE"; or a PostgreSQL database
  // (postgresql://USER@HOST:PORT/DB or a libpq key=value string), shared by several servers.
  std::string store;
  // The site (map) this server maps in a PostgreSQL store: [a-z0-9_-]{1,40} ("default"). Robots
  // that name another site in OpenSession are refused.
  std::string site = "default";
  // The site's writer lease in a PostgreSQL store: it lasts lease_ttl_s after each renewal,
  // renewed every lease_renew_s; a standby takes over within about lease_ttl_s of the writer's
  // death (6 s, 1.5 s).
  double lease_ttl_s = 6.0;
  double lease_renew_s = 1.5;
  std::string http = "off";                // HTTP/JSON API address HOST:PORT or "off"
  int max_message_mb = 64;                 // largest gRPC message accepted, MiB (64)
  int queue_capacity = 32;                 // keyframes waiting for the mapping worker (32)
  int max_detections = 512;                // detections per keyframe accepted (512)
  int max_image_px = 4096;                 // largest accepted image width or height, px (4096)
  double map_extent_m = 10'000.0;          // keyframe positions beyond +-this (any axis) refused, m
  double max_future_s = 86'400.0;          // keyframe stamps later than now + this refused, s (1 day)
  // A keyframe whose seq follows its session's last one may be stamped at most this much
  // earlier than it, ms (1000).
  double stamp_backwards_ms = 1000.0;
  int max_watchers = 64;  // WatchObjects streams at once (each holds a thread); more: RESOURCE_EXHAUSTED
  int decode_slots = 4;  // keyframes validated (images decoded) at once; more wait (4)
  // HTTP /api/events streams at once (each holds one of the HTTP API's 32 worker threads); more
  // are answered 503. In [0, 16].
  int max_event_clients = 8;
  // A checkpoint of the derived map is written after this many mapped keyframes or this many
  // seconds with keyframes, whichever comes first, and at shutdown (100, 300 s).
  int checkpoint_keyframes = 100;
  double checkpoint_interval_s = 300.0;
  // The object table (what read-only query servers and SQL tools read) gets the map's changes
  // at most this often, s (1.0); in (0, 60].
  double publish_interval_s = 1.0;
  // Retention of the raw keyframe images, applied after each checkpoint to keyframes whose
  // products are stored: images older than raw_keep_days are dropped (-1 = kept forever,
  // 0 = dropped once the products exist), and only the newest raw_keep_last keyframes keep
  // theirs (-1 = no limit). Without images a keyframe cannot be re-processed with other
  // product options (`loci reprocess` skips it).
  double raw_keep_days = -1;
  int64_t raw_keep_last = -1;
  // Server-side detector (section `detector`: `enabled` (default false), `mode` ("missing":
  // keyframes that arrive without detections; "all": every keyframe, the robot's boxes as the
  // fallback), `threads` (detector instances, each on its own thread, default 1), plus the keys
  // of detection::DetectorOptions).
  bool detector_enabled = false;
  std::string detector_mode = "missing";
  int detector_threads = 1;
  YAML::Node detector_config;
  std::string config_dir;    // directory of the config file (relative paths)
  std::string classes_file;  // class lists; "" = <source>/config/classes.yaml
  // T_base_odom per robot name: the robot's odometry frame in the base frame, the first
  // robot's odometry frame (server/map/map_frame.h); identity when absent.
  std::map<std::string, SE3d> T_base_odom;
  MapOptions map;
  // Place recognition and geometric verification (section `place`), used to align robots.
  ::loci::place::PlaceOptions place;
  // Robots that start anywhere and loop closure (section `align`, server/align/).
  AlignOptions align;
  // The keyframe pose graph loop closure solves (section `graph`, server/graph/).
  GraphOptions graph;

  // Reads a `detector:` section (keys above); InvalidArgument for a bad mode or thread count.
  Status ReadDetector(const YAML::Node& detector);
  // Replaces the detector section with the one of a file holding only `detector:` (loci-server
  // --detector, e.g. config/server-detector.yaml).
  Status DetectorFromYamlFile(const std::string& path);
  // Reads config/server.yaml (sections server, detector, map, place, align, sessions, graph); then the classes
  // file.
  Status FromYamlFile(const std::string& path);
  // Checks the keyframe limits above (called by FromYamlFile and MapServer::Open).
  Status ValidateLimits() const;
  // Loads classes_file into map (called by FromYamlFile and by users without a config).
  Status LoadClasses();
};

}  // namespace loci::server
