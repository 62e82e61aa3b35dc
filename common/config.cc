#include "common/config.h"

#include <cstdlib>
#include <filesystem>

namespace loci {

StatusOr<YAML::Node> LoadYamlFile(const std::string& path) {
  if (!std::filesystem::exists(path)) {
    return absl::NotFoundError(absl::StrCat("config file not found: ", path));
  }
  try {
    return YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": ", e.what()));
  }
}

StatusOr<PinholeCamera> CameraPreset(const std::string& name) {
  if (name == "tum_fr1") return PinholeCamera::TumFr1();
  if (name == "tum_fr2") return PinholeCamera::TumFr2();
  if (name == "tum_fr3") return PinholeCamera::TumFr3();
  return absl::InvalidArgumentError(
      absl::StrCat("unknown camera preset '", name, "' (known: tum_fr1, tum_fr2, tum_fr3)"));
}

StatusOr<PinholeCamera> CameraFromYaml(const YAML::Node& node) {
  if (!node) return absl::InvalidArgumentError("camera: missing");
  if (node.IsScalar()) return CameraPreset(node.as<std::string>());
  PinholeCamera cam;
  if (node["preset"]) {
    LOCI_ASSIGN_OR_RETURN(cam, CameraPreset(node["preset"].as<std::string>()));
  }
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "fx", &cam.fx));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "fy", &cam.fy));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "cx", &cam.cx));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "cy", &cam.cy));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "width", &cam.width_px));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "height", &cam.height_px));
  LOCI_RETURN_IF_ERROR(cam.Validate());
  return cam;
}

std::string SourceDir() {
  // An installed copy (docker/, a package) points LOCI_HOME at its config/ and models/.
  const char* home = std::getenv("LOCI_HOME");
  return home && *home ? home : LOCI_SOURCE_DIR;
}

std::string DataDirFromEnv() {
  const char* d = std::getenv("LOCI_DATA");
  return d ? d : "";
}

}  // namespace loci
