// YAML configuration (yaml-cpp). Each component declares an Options struct with documented
// fields and a FromYaml(node) that fills only the keys present, so defaults live in one place.
#pragma once

#include <string>

#include <yaml-cpp/yaml.h>

#include "common/camera.h"
#include "common/status.h"

namespace loci {

// Parses a YAML file; NotFound / InvalidArgument with the file and line on error.
StatusOr<YAML::Node> LoadYamlFile(const std::string& path);

// Reads node[key] into *out when present; InvalidArgument naming the key when ill-typed.
template <typename T>
Status ReadOptional(const YAML::Node& node, const char* key, T* out) {
  if (!node || !node[key]) return absl::OkStatus();
  try {
    *out = node[key].as<T>();
  } catch (const YAML::Exception& e) {
    return absl::InvalidArgumentError(absl::StrCat("config key '", key, "': ", e.what()));
  }
  return absl::OkStatus();
}

// Camera from a node {fx, fy, cx, cy, width, height} or a named preset "tum_fr1|2|3".
StatusOr<PinholeCamera> CameraFromYaml(const YAML::Node& node);
StatusOr<PinholeCamera> CameraPreset(const std::string& name);

// Where the shipped config/, models/ and tests/data live: $LOCI_HOME when set, else the source
// directory baked in at build time.
std::string SourceDir();
// $LOCI_DATA if set, else "".
std::string DataDirFromEnv();

}  // namespace loci
