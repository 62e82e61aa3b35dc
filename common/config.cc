#include "common/config.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <regex>
#include <string>
#include <system_error>
#include <vector>

#include "absl/strings/str_join.h"

namespace loci {
namespace {

std::atomic<bool> g_strict_config{false};
thread_local const std::string* t_config_file = nullptr;

}  // namespace

void SetStrictConfig(bool strict) { g_strict_config.store(strict); }
bool StrictConfig() { return g_strict_config.load(); }

ConfigFileScope::ConfigFileScope(std::string path)
    : path_(std::move(path)), previous_(t_config_file) {
  t_config_file = &path_;
}

ConfigFileScope::~ConfigFileScope() { t_config_file = previous_; }

Status CheckKnownKeys(const YAML::Node& node, const std::string& section,
                      std::span<const char* const> known) {
  if (!node || !node.IsMap()) return absl::OkStatus();
  const std::string file = t_config_file ? *t_config_file : "config";
  const std::string where =
      section.empty() ? "at the top level" : absl::StrCat("in '", section, "'");
  std::vector<std::string> problems;
  for (const auto& kv : node) {
    const std::string key = kv.first.Scalar();
    if (std::find(known.begin(), known.end(), key) != known.end()) continue;
    problems.push_back(absl::StrCat(file, ":", kv.first.Mark().line + 1, ": unknown key '", key,
                                    "' ", where, " (known: ", absl::StrJoin(known, ", "), ")"));
    if (!StrictConfig()) spdlog::warn("{}", problems.back());
  }
  if (problems.empty() || !StrictConfig()) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrJoin(problems, "; "));
}

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

StatusOr<CameraCalibration> CameraPreset(const std::string& name) {
  using Cal = CameraCalibration;
  if (name == "tum_fr1") {
    return Cal{PinholeCamera::TumFr1(), LensDistortion::TumFr1(), kKinectV1LineTimeUs};
  }
  if (name == "tum_fr2") {
    return Cal{PinholeCamera::TumFr2(), LensDistortion::TumFr2(), kKinectV1LineTimeUs};
  }
  if (name == "tum_fr3") return Cal{PinholeCamera::TumFr3(), LensDistortion{}};
  return absl::InvalidArgumentError(
      absl::StrCat("unknown camera preset '", name, "' (known: tum_fr1, tum_fr2, tum_fr3)"));
}

std::string TumCameraPresetForFolder(const std::string& dir) {
  std::string name = std::filesystem::path(dir).lexically_normal().filename().string();
  if (name.empty()) name = std::filesystem::path(dir).lexically_normal().parent_path().filename();
  static const std::regex kKinect("(^|_)(freiburg|fr)([123])(_|$)");
  std::smatch m;
  if (!std::regex_search(name, m, kKinect)) return "";
  return absl::StrCat("tum_fr", m[3].str());
}

namespace {

Status ReadDistortion(const YAML::Node& node, LensDistortion* out) {
  if (!node["distortion"]) return absl::OkStatus();
  std::vector<double> c;
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "distortion", &c));
  if (c.size() != 5) {
    return absl::InvalidArgumentError(absl::StrCat(
        "camera.distortion: give 5 coefficients [k1, k2, p1, p2, k3], not ", c.size()));
  }
  *out = {c[0], c[1], c[2], c[3], c[4]};
  return absl::OkStatus();
}

}  // namespace

StatusOr<CameraCalibration> CameraFromYaml(const YAML::Node& node) {
  if (!node) return absl::InvalidArgumentError("camera: missing");
  if (node.IsScalar()) return CameraPreset(node.as<std::string>());
  LOCI_RETURN_IF_ERROR(CheckKnownKeys(
      node, "camera",
      {"preset", "fx", "fy", "cx", "cy", "width", "height", "distortion", "line_time_us"}));
  CameraCalibration cal;
  if (node["preset"]) {
    LOCI_ASSIGN_OR_RETURN(cal, CameraPreset(node["preset"].as<std::string>()));
  }
  PinholeCamera& cam = cal.intrinsics;
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "fx", &cam.fx));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "fy", &cam.fy));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "cx", &cam.cx));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "cy", &cam.cy));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "width", &cam.width_px));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "height", &cam.height_px));
  LOCI_RETURN_IF_ERROR(ReadDistortion(node, &cal.distortion));
  LOCI_RETURN_IF_ERROR(ReadOptional(node, "line_time_us", &cal.line_time_us));
  if (!std::isfinite(cal.line_time_us) || std::abs(cal.line_time_us) > 1000) {
    return absl::InvalidArgumentError(absl::StrCat("camera.line_time_us ", cal.line_time_us,
                                                   " is not within [-1000, 1000] us"));
  }
  LOCI_RETURN_IF_ERROR(cam.Validate());
  LOCI_RETURN_IF_ERROR(cal.distortion.Validate(cam));
  return cal;
}

std::string ResolveResourceDir(const char* home, const std::string& exe,
                               const std::string& source_dir) {
  if (home != nullptr && *home != '\0') return home;
  if (!exe.empty()) {
    // bin/X -> share/loci; the build tree's share/loci holds only the viewer, so it falls through.
    const std::filesystem::path installed =
        (std::filesystem::path(exe).parent_path().parent_path() / "share/loci").lexically_normal();
    std::error_code ec;
    if (std::filesystem::is_directory(installed / "config", ec)) return installed.string();
  }
  return source_dir;
}

std::string SourceDir() {
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ResolveResourceDir(std::getenv("LOCI_HOME"), ec ? std::string() : exe.string(),
                            LOCI_SOURCE_DIR);
}

std::string DataDirFromEnv() {
  const char* d = std::getenv("LOCI_DATA");
  return d ? d : "";
}

}  // namespace loci
