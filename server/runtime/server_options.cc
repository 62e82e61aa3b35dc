#include "server/runtime/server_options.h"

#include <filesystem>
#include <vector>

#include "common/config.h"
#include "server/detect/keyframe_detection.h"

namespace loci::server {

Status ServerOptions::ReadDetector(const YAML::Node& d) {
  LOCI_RETURN_IF_ERROR(ReadOptional(d, "enabled", &detector_enabled));
  LOCI_RETURN_IF_ERROR(ReadOptional(d, "mode", &detector_mode));
  LOCI_RETURN_IF_ERROR(ReadOptional(d, "threads", &detector_threads));
  LOCI_RETURN_IF_ERROR(ParseDetectMode(detector_mode).status());
  if (detector_threads < 1 || detector_threads > 16) {
    return absl::InvalidArgumentError("detector.threads must be in [1, 16]");
  }
  detector_config = YAML::Clone(d);  // the detector's own keys (checked when it is made)
  for (const char* key : {"enabled", "mode", "threads"}) detector_config.remove(key);
  // The server detector's boxes shape the products.
  if (detector_enabled) {
    map.NoteProductsInput("detector " + detector_mode + "\n" + YAML::Dump(detector_config));
  }
  return absl::OkStatus();
}

Status ServerOptions::DetectorFromYamlFile(const std::string& path) {
  LOCI_ASSIGN_OR_RETURN(YAML::Node root, LoadYamlFile(path));
  const ConfigFileScope scope(path);
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(root, "", {"detector"}));
  if (!root["detector"]) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": no `detector:` section"));
  }
  return ReadDetector(root["detector"]);
}

Status ServerOptions::FromYamlFile(const std::string& path) {
  LOCI_ASSIGN_OR_RETURN(YAML::Node root, LoadYamlFile(path));
  const ConfigFileScope scope(path);
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(
      root, "", {"server", "detector", "map", "place", "align", "sessions", "graph"}));
  if (const YAML::Node s = root["server"]) {
    LOCI_RETURN_IF_ERROR(CheckKnownKeys(
        s, "server",
        {"listen", "db", "store", "site", "lease_ttl_s", "lease_renew_s", "http", "max_message_mb", "queue_capacity", "max_detections",
         "max_image_px", "map_extent_m", "max_future_s", "stamp_backwards_ms", "decode_slots",
         "max_watchers", "classes_file", "max_event_clients", "checkpoint_keyframes",
         "checkpoint_interval_s", "publish_interval_s", "raw_keep_days", "raw_keep_last"}));
    LOCI_RETURN_IF_ERROR(ReadOptional(s, "listen", &listen));
    LOCI_RETURN_IF_ERROR(ReadOptional(s, "db", &db_path));
    LOCI_RETURN_IF_ERROR(ReadOptional(s, "store", &store));
    LOCI_RETURN_IF_ERROR(ReadOptional(s, "site", &site));
    LOCI_RETURN_IF_ERROR(ReadOptional(s, "lease_ttl_s", &lease_ttl_s));
    LOCI_RETURN_IF_ERROR(ReadOptional(s, "lease_renew_s", &lease_renew_s));
    LOCI_RETURN_IF_ERROR(ReadOptional(s, "http", &http));
    LOCI_RETURN_IF_ERROR(ReadOptional(s, "max_message_mb", &max_message_mb));
    LOCI_RETURN_IF_ERROR(ReadOptional(s, "queue_capacity", &queue_capacity));
    LOCI_RETURN_IF_ERROR(ReadOptional(s, "max_detections", &max_detections));
    LOCI_RETURN_IF_ERROR(ReadOptional(s, "max_image_px", &max_image_px));
    LOCI_RETURN_IF_ERROR(ReadOptional(s, "map_extent_m", &map_extent_m));
    LOCI_RETURN_IF_ERROR(ReadOptional(s, "max_future_s", &max_future_s));
    LOCI_RETURN_IF_ERROR(ReadOptional(s, "stamp_backwards_ms", &stamp_backwards_ms));
    LOCI_RETURN_IF_ERROR(ReadOptional(s, "decode_slots", &decode_slots));
    LOCI_RETURN_IF_ERROR(ReadOptional(s, "max_watchers", &max_watchers));
    LOCI_RETURN_IF_ERROR(ReadOptional(s, "max_event_clients", &max_event_clients));
    LOCI_RETURN_IF_ERROR(ReadOptional(s, "classes_file", &classes_file));
    LOCI_RETURN_IF_ERROR(ReadOptional(s, "checkpoint_keyframes", &checkpoint_keyframes));
    LOCI_RETURN_IF_ERROR(ReadOptional(s, "checkpoint_interval_s", &checkpoint_interval_s));
    LOCI_RETURN_IF_ERROR(ReadOptional(s, "publish_interval_s", &publish_interval_s));
    LOCI_RETURN_IF_ERROR(ReadOptional(s, "raw_keep_days", &raw_keep_days));
    LOCI_RETURN_IF_ERROR(ReadOptional(s, "raw_keep_last", &raw_keep_last));
    if (!classes_file.empty() && std::filesystem::path(classes_file).is_relative() &&
        !std::filesystem::exists(classes_file)) {
      classes_file = (std::filesystem::path(path).parent_path() / classes_file).string();
    }
  }
  config_dir = std::filesystem::path(path).parent_path().string();
  if (const YAML::Node d = root["detector"]) LOCI_RETURN_IF_ERROR(ReadDetector(d));
  LOCI_RETURN_IF_ERROR(LoadClasses());
  LOCI_RETURN_IF_ERROR(map.FromYaml(root["map"]));
  LOCI_RETURN_IF_ERROR(place.FromYaml(root["place"]));
  LOCI_RETURN_IF_ERROR(align.FromYaml(root["align"]));
  LOCI_RETURN_IF_ERROR(graph.FromYaml(root["graph"]));
  if (const YAML::Node sessions = root["sessions"]) {
    for (const auto& kv : sessions) {
      const std::string robot = kv.first.as<std::string>();
      LOCI_RETURN_IF_ERROR(
          CheckKnownKeys(kv.second, "sessions." + robot, {"t_base_odom_m", "q_base_odom_wxyz"}));
      std::vector<double> t{0, 0, 0}, q{1, 0, 0, 0};
      LOCI_RETURN_IF_ERROR(ReadOptional(kv.second, "t_base_odom_m", &t));
      LOCI_RETURN_IF_ERROR(ReadOptional(kv.second, "q_base_odom_wxyz", &q));
      if (t.size() != 3 || q.size() != 4) {
        return absl::InvalidArgumentError(
            absl::StrCat(path, ": sessions.", robot,
                         " needs t_base_odom_m [x,y,z] and q_base_odom_wxyz [w,x,y,z]"));
      }
      LOCI_RETURN_IF_ERROR(ValidatePose(Vec3d(t[0], t[1], t[2]), q[0], q[1], q[2], q[3]));
      T_base_odom[robot] = MakeSE3(Vec3d(t[0], t[1], t[2]), Quatd(q[0], q[1], q[2], q[3]));
    }
  }
  if (max_message_mb < 1 || max_message_mb > 1024) {
    return absl::InvalidArgumentError("server.max_message_mb must be in [1, 1024]");
  }
  if (queue_capacity < 1) return absl::InvalidArgumentError("server.queue_capacity must be >= 1");
  return ValidateLimits();
}

Status ServerOptions::ValidateLimits() const {
  if (!(map_extent_m > 0 && map_extent_m <= 1e6)) {
    return absl::InvalidArgumentError("server.map_extent_m must be in (0, 1e6]");
  }
  if (!(max_future_s >= 0 && max_future_s <= 1e7)) {
    return absl::InvalidArgumentError("server.max_future_s must be in [0, 1e7]");
  }
  if (!(stamp_backwards_ms >= 0 && stamp_backwards_ms <= 1e7)) {
    return absl::InvalidArgumentError("server.stamp_backwards_ms must be in [0, 1e7]");
  }
  if (max_watchers < 0 || max_watchers > 10'000) {
    return absl::InvalidArgumentError("server.max_watchers must be in [0, 10000]");
  }
  if (max_event_clients < 0 || max_event_clients > 16) {
    return absl::InvalidArgumentError("server.max_event_clients must be in [0, 16]");
  }
  if (decode_slots < 1 || decode_slots > 256) {
    return absl::InvalidArgumentError("server.decode_slots must be in [1, 256]");
  }
  if (checkpoint_keyframes < 1 || !(checkpoint_interval_s > 0)) {
    return absl::InvalidArgumentError(
        "server.checkpoint_keyframes must be >= 1 and server.checkpoint_interval_s > 0");
  }
  if (!(publish_interval_s > 0 && publish_interval_s <= 60)) {
    return absl::InvalidArgumentError("server.publish_interval_s must be in (0, 60]");
  }
  if (!(lease_ttl_s >= 1 && lease_ttl_s <= 3600 && lease_renew_s > 0 &&
        lease_renew_s < lease_ttl_s)) {
    return absl::InvalidArgumentError(
        "server.lease_ttl_s must be in [1, 3600] and server.lease_renew_s in (0, lease_ttl_s)");
  }
  if (!(raw_keep_days == -1 || raw_keep_days >= 0) || raw_keep_last < -1) {
    return absl::InvalidArgumentError(
        "server.raw_keep_days must be -1 (keep) or >= 0, server.raw_keep_last -1 or >= 0");
  }
  return absl::OkStatus();
}

Status ServerOptions::LoadClasses() {
  std::string file = classes_file.empty() ? SourceDir() + "/config/classes.yaml" : classes_file;
  if (!std::filesystem::exists(file)) {
    if (classes_file.empty()) return absl::OkStatus();  // installed without sources: defaults
    return absl::NotFoundError(absl::StrCat("classes file not found: ", file));
  }
  LOCI_ASSIGN_OR_RETURN(YAML::Node node, LoadYamlFile(file));
  const ConfigFileScope scope(file);
  // dynamic_weight is loci-track's (TrackerOptions::ClassWeightsFromYaml).
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(
      node, "", {"mapped", "dynamic_classes", "dynamic_weight", "max_size_m", "max_height_m",
                 "max_thickness_m", "stand_m", "stays_days", "top"}));
  return map.ClassesFromYaml(node);
}

}  // namespace loci::server
