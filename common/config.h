// YAML configuration (yaml-cpp). Each component declares an Options struct with documented
// fields and a FromYaml(node) that fills only the keys present, so defaults live in one place.
#pragma once

#include <yaml-cpp/yaml.h>

#include <initializer_list>
#include <span>
#include <string>

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

// Unknown keys: each FromYaml lists the keys of its sections, and a key outside the list (a
// misspelling) is reported with file, line, section and key: spdlog::warn, or with strict
// checking (`--strict-config` of loci-server and loci-track) an InvalidArgument error.
// Absent and non-map nodes pass.
Status CheckKnownKeys(const YAML::Node& node, const std::string& section,
                      std::span<const char* const> known);
inline Status CheckKnownKeys(const YAML::Node& node, const std::string& section,
                             std::initializer_list<const char*> known) {
  return CheckKnownKeys(node, section, std::span<const char* const>(known.begin(), known.size()));
}
// Process-wide: unknown keys are errors (true) or warnings (false, the default).
void SetStrictConfig(bool strict);
bool StrictConfig();
// Names the file that CheckKnownKeys reports on this thread while the scope lives (nestable).
class ConfigFileScope {
 public:
  explicit ConfigFileScope(std::string path);
  ~ConfigFileScope();
  ConfigFileScope(const ConfigFileScope&) = delete;
  ConfigFileScope& operator=(const ConfigFileScope&) = delete;

 private:
  std::string path_;
  const std::string* previous_;
};

// Camera from a node {preset, fx, fy, cx, cy, width, height, distortion: [k1, k2, p1, p2, k3]}
// or a named preset "tum_fr1|2|3" (intrinsics and distortion). Keys override the preset's; without
// a preset, an absent `distortion` means pinhole images.
StatusOr<CameraCalibration> CameraFromYaml(const YAML::Node& node);
StatusOr<CameraCalibration> CameraPreset(const std::string& name);
// The camera preset a TUM RGB-D folder's name gives ("tum_fr1", "tum_fr2", "tum_fr3"): its last
// path component names the Kinect as TUM does (rgbd_dataset_freiburg3_long_office_household) or
// as scripts/fetch-tum.sh does (tum_fr2_desk). "" when the name says nothing.
std::string TumCameraPresetForFolder(const std::string& dir);

// Where the shipped config/ and models/ (and, in the source tree, tests/data) live, first of:
// $LOCI_HOME when set; <dir of this executable>/../share/loci when it holds config/ (an
// installed copy: `cmake --install`, the .deb, the container images); the source directory
// baked in at build time.
std::string SourceDir();
// SourceDir()'s order with its inputs given: `home` ($LOCI_HOME, may be null or empty), `exe`
// (path of the running executable, may be empty) and `source_dir` (the baked-in tree).
std::string ResolveResourceDir(const char* home, const std::string& exe,
                               const std::string& source_dir);
// $LOCI_DATA if set, else "".
std::string DataDirFromEnv();

}  // namespace loci
