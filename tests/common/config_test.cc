#include "common/config.h"

#include <gtest/gtest.h>
#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

#include <cstdlib>
#include <filesystem>
#include <sstream>

#include "tests/support/temp_dir.h"

namespace loci {
namespace {

TEST(Config, ShippedCameraFilesLoad) {
  for (const char* name : {"tum_fr1", "tum_fr2", "tum_fr3"}) {
    const std::string path = std::string(LOCI_SOURCE_DIR) + "/config/camera_" + name + ".yaml";
    auto node = LoadYamlFile(path);
    ASSERT_TRUE(node.ok()) << node.status();
    auto cam = CameraFromYaml((*node)["camera"]);
    ASSERT_TRUE(cam.ok()) << cam.status();
    auto preset = CameraPreset(name);
    EXPECT_DOUBLE_EQ(cam->intrinsics.fx, preset->intrinsics.fx);
    EXPECT_EQ(cam->intrinsics.width_px, 640);
    // The files and the presets give the same lens distortion (fr1, fr2: TUM's; fr3: none).
    EXPECT_DOUBLE_EQ(cam->distortion.k1, preset->distortion.k1) << name;
    EXPECT_DOUBLE_EQ(cam->distortion.k3, preset->distortion.k3) << name;
    EXPECT_EQ(cam->distortion.IsZero(), std::string(name) == "tum_fr3") << name;
    // ... and the same rolling shutter (the Kinect v1's for fr1 and fr2; fr3: none measured).
    EXPECT_DOUBLE_EQ(cam->line_time_us, preset->line_time_us) << name;
    EXPECT_EQ(cam->line_time_us == 0, std::string(name) == "tum_fr3") << name;
  }
}

TEST(Config, CameraLineTimeIsReadAndChecked) {
  auto plain =
      CameraFromYaml(YAML::Load("{fx: 500, fy: 500, cx: 320, cy: 240, width: 640, height: 480}"));
  ASSERT_TRUE(plain.ok()) << plain.status();
  EXPECT_EQ(plain->line_time_us, 0.0);  // a camera described by its intrinsics: global shutter
  auto fr1 = CameraFromYaml(YAML::Load("{preset: tum_fr1, fx: 520}"));
  ASSERT_TRUE(fr1.ok()) << fr1.status();
  EXPECT_DOUBLE_EQ(fr1->line_time_us, kKinectV1LineTimeUs);
  auto global = CameraFromYaml(YAML::Load("{preset: tum_fr1, line_time_us: 0}"));
  ASSERT_TRUE(global.ok()) << global.status();
  EXPECT_EQ(global->line_time_us, 0.0);
  for (const char* bad : {"{preset: tum_fr1, line_time_us: 5000}",
                          "{preset: tum_fr1, line_time_us: .nan}",
                          "{preset: tum_fr1, line_time_us: fast}"}) {
    auto r = CameraFromYaml(YAML::Load(bad));
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_NE(r.status().message().find("line_time_us"), std::string::npos) << r.status();
  }
}

TEST(Config, CameraDistortionIsReadAndChecked) {
  // Intrinsics alone: pinhole images.
  auto plain =
      CameraFromYaml(YAML::Load("{fx: 500, fy: 500, cx: 320, cy: 240, width: 640, height: 480}"));
  ASSERT_TRUE(plain.ok()) << plain.status();
  EXPECT_TRUE(plain->distortion.IsZero());
  // A preset keeps its distortion when only intrinsics are overridden; `distortion` replaces it.
  auto over = CameraFromYaml(YAML::Load("{preset: tum_fr1, fx: 520}"));
  ASSERT_TRUE(over.ok()) << over.status();
  EXPECT_DOUBLE_EQ(over->distortion.k2, LensDistortion::TumFr1().k2);
  auto given = CameraFromYaml(YAML::Load("{preset: tum_fr1, distortion: [0.1, -0.2, 0, 0, 0]}"));
  ASSERT_TRUE(given.ok()) << given.status();
  EXPECT_DOUBLE_EQ(given->distortion.k1, 0.1);
  EXPECT_DOUBLE_EQ(given->distortion.k3, 0.0);
  // Four coefficients, a string, and a model that folds over inside the image are errors.
  for (const char* bad : {"{preset: tum_fr1, distortion: [0.1, -0.2, 0, 0]}",
                          "{preset: tum_fr1, distortion: abc}",
                          "{preset: tum_fr1, distortion: [0, -2.0, 0, 0, 0]}"}) {
    auto r = CameraFromYaml(YAML::Load(bad));
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_NE(r.status().message().find("distortion"), std::string::npos) << r.status();
  }
}

TEST(Config, BadCameraIsRejected) {
  YAML::Node n = YAML::Load("{fx: -1, fy: 500, cx: 320, cy: 240, width: 640, height: 480}");
  EXPECT_FALSE(CameraFromYaml(n).ok());
  EXPECT_FALSE(CameraFromYaml(YAML::Load("tum_fr9")).ok());
  YAML::Node typed = YAML::Load("{fx: abc, fy: 500, cx: 320, cy: 240, width: 640, height: 480}");
  auto r = CameraFromYaml(typed);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("fx"), std::string::npos);
  EXPECT_EQ(LoadYamlFile("/nonexistent.yaml").status().code(), absl::StatusCode::kNotFound);
}

// Captures what spdlog logs while alive (the default logger is swapped and restored).
class LogCapture {
 public:
  LogCapture() : previous_(spdlog::default_logger()) {
    auto sink = std::make_shared<spdlog::sinks::ostream_sink_mt>(out_);
    spdlog::set_default_logger(std::make_shared<spdlog::logger>("capture", sink));
  }
  ~LogCapture() { spdlog::set_default_logger(previous_); }
  std::string text() const { return out_.str(); }

 private:
  std::ostringstream out_;
  std::shared_ptr<spdlog::logger> previous_;
};

TEST(ConfigKeys, UnknownKeyWarnsWithFileLineSectionAndKey) {
  const YAML::Node n = YAML::Load("voxel_m: 0.04\nvoxle_m: 0.02\n");
  LogCapture log;
  const ConfigFileScope scope("server.yaml");
  EXPECT_TRUE(CheckKnownKeys(n, "map.cloud", {"voxel_m", "sor_mean_k"}).ok());
  const std::string text = log.text();
  EXPECT_NE(text.find("server.yaml:2: unknown key 'voxle_m' in 'map.cloud'"), std::string::npos)
      << text;
  EXPECT_NE(text.find("known: voxel_m, sor_mean_k"), std::string::npos) << text;
  EXPECT_EQ(text.find("'voxel_m'"), std::string::npos) << "a known key was reported: " << text;
}

TEST(ConfigKeys, StrictMakesUnknownKeysErrors) {
  const YAML::Node n = YAML::Load("{a: 1, b: 2, c: 3}");
  SetStrictConfig(true);
  const Status strict = CheckKnownKeys(n, "", {"a"});
  const Status known = CheckKnownKeys(n, "", {"a", "b", "c"});
  SetStrictConfig(false);
  EXPECT_EQ(strict.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(strict.message().find("unknown key 'b' at the top level"), std::string::npos) << strict;
  EXPECT_NE(strict.message().find("unknown key 'c'"), std::string::npos) << strict;
  EXPECT_TRUE(known.ok()) << known;
  EXPECT_TRUE(CheckKnownKeys(n, "", {"a"}).ok());  // back to warnings
}

TEST(ConfigKeys, AbsentAndNonMapNodesPass) {
  SetStrictConfig(true);
  EXPECT_TRUE(CheckKnownKeys(YAML::Node(), "s", {"a"}).ok());
  EXPECT_TRUE(CheckKnownKeys(YAML::Load("[1, 2]"), "s", {"a"}).ok());
  EXPECT_TRUE(CheckKnownKeys(YAML::Load("scalar"), "s", {"a"}).ok());
  SetStrictConfig(false);
}

TEST(ConfigKeys, FileScopesNest) {
  const YAML::Node n = YAML::Load("{zz: 1}");
  SetStrictConfig(true);
  std::string inner, outer;
  {
    const ConfigFileScope a("outer.yaml");
    {
      const ConfigFileScope b("inner.yaml");
      inner = std::string(CheckKnownKeys(n, "", {}).message());
    }
    outer = std::string(CheckKnownKeys(n, "", {}).message());
  }
  SetStrictConfig(false);
  EXPECT_EQ(inner.rfind("inner.yaml:1:", 0), 0u) << inner;
  EXPECT_EQ(outer.rfind("outer.yaml:1:", 0), 0u) << outer;
}

TEST(ConfigKeys, CameraKeysAreChecked) {
  SetStrictConfig(true);
  auto cam = CameraFromYaml(YAML::Load("{preset: tum_fr1, fxx: 500}"));
  SetStrictConfig(false);
  ASSERT_FALSE(cam.ok());
  EXPECT_NE(cam.status().message().find("'fxx'"), std::string::npos) << cam.status();
}

// Resource lookup order: $LOCI_HOME, then <exe dir>/../share/loci when it holds config/ (an
// install), then the source tree baked in at build time.
class ResourceDir : public testing::TempDirTest {};

TEST_F(ResourceDir, HomeThenInstalledShareThenSourceTree) {
  namespace fs = std::filesystem;
  const std::string exe = Path("prefix/bin/loci-server");
  const std::string share = Path("prefix/share/loci");
  fs::create_directories(Path("prefix/bin"));
  // No share/loci/config beside the binary (a build tree has only share/loci/viewer there).
  fs::create_directories(share + "/viewer");
  EXPECT_EQ(ResolveResourceDir(nullptr, exe, "/src/loci"), "/src/loci");
  EXPECT_EQ(ResolveResourceDir("", exe, "/src/loci"), "/src/loci");
  EXPECT_EQ(ResolveResourceDir(nullptr, "", "/src/loci"), "/src/loci");
  // An installed tree: share/loci/config beside bin/.
  fs::create_directories(share + "/config");
  EXPECT_EQ(ResolveResourceDir(nullptr, exe, "/src/loci"), share);
  EXPECT_EQ(ResolveResourceDir("", exe, "/src/loci"), share);
  // $LOCI_HOME wins over both.
  EXPECT_EQ(ResolveResourceDir("/opt/loci", exe, "/src/loci"), "/opt/loci");
}

TEST(ResourceDirEnv, SourceDirFollowsLociHome) {
  const char* saved = std::getenv("LOCI_HOME");
  const std::string previous = saved != nullptr ? saved : "";
  setenv("LOCI_HOME", "/somewhere/loci", 1);
  EXPECT_EQ(SourceDir(), "/somewhere/loci");
  unsetenv("LOCI_HOME");
  // The test binary lives in <build>/tests, whose ../share/loci has no config/: the source tree.
  EXPECT_EQ(SourceDir(), LOCI_SOURCE_DIR);
  if (saved != nullptr) setenv("LOCI_HOME", previous.c_str(), 1);
}

}  // namespace
}  // namespace loci
