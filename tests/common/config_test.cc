#include "common/config.h"

#include <filesystem>

#include <gtest/gtest.h>

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
    EXPECT_DOUBLE_EQ(cam->fx, preset->fx);
    EXPECT_EQ(cam->width_px, 640);
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

}  // namespace
}  // namespace loci
