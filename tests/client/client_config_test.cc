// The client's configuration (LoadClientConfig): config/client.yaml's top level and sections,
// and a sequence's camera.yaml. Misspelt keys warn, or fail with strict checking.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "client/app/track_pipeline.h"
#include "common/config.h"

namespace loci {
namespace {

class ClientConfigTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("loci_client_config_test_" + std::to_string(getpid()));
    std::filesystem::create_directories(dir_ / "seq");
  }
  void TearDown() override {
    SetStrictConfig(false);
    std::filesystem::remove_all(dir_);
  }
  std::string Write(const std::string& name, const std::string& text) const {
    const std::string path = (dir_ / name).string();
    std::ofstream(path) << text;
    return path;
  }
  std::string SeqDir() const { return (dir_ / "seq").string(); }
  // LoadClientConfig with strict checking on or off.
  StatusOr<ClientConfig> Load(const std::string& client_yaml, bool strict) const {
    SetStrictConfig(strict);
    auto c = LoadClientConfig(client_yaml, SeqDir());
    SetStrictConfig(false);
    return c;
  }
  std::filesystem::path dir_;
};

TEST_F(ClientConfigTest, StreamingSectionIsRead) {
  const std::string path = Write("client.yaml", "streaming:\n  max_unacked: 4\n  jpeg_quality: 70\n");
  auto c = Load(path, /*strict=*/true);
  ASSERT_TRUE(c.ok()) << c.status();
  EXPECT_EQ(c->streaming.max_unacked, 4);
  EXPECT_EQ(c->streaming.jpeg_quality, 70);
}

TEST_F(ClientConfigTest, MisspeltTopLevelKeyWarnsOrFailsWhenStrict) {
  // `streming` is a misspelt `streaming`: its value must not be taken, and the key is reported.
  const std::string path = Write("client.yaml", "tracker:\n  min_depth_m: 0.2\nstreming:\n"
                                                "  max_unacked: 4\n");
  auto lenient = Load(path, /*strict=*/false);
  ASSERT_TRUE(lenient.ok()) << lenient.status();
  EXPECT_DOUBLE_EQ(lenient->tracker.min_depth_m, 0.2);
  EXPECT_EQ(lenient->streaming.max_unacked, MapClientOptions{}.max_unacked);
  auto strict = Load(path, /*strict=*/true);
  ASSERT_EQ(strict.status().code(), absl::StatusCode::kInvalidArgument) << strict.status();
  EXPECT_NE(strict.status().message().find(path + ":3: unknown key 'streming' at the top level"),
            std::string::npos)
      << strict.status();
}

TEST_F(ClientConfigTest, MisspeltStreamingKeyFailsWhenStrict) {
  const std::string path = Write("client.yaml", "streaming:\n  max_unacked: 4\n  jpg_quality: 50\n");
  auto lenient = Load(path, /*strict=*/false);
  ASSERT_TRUE(lenient.ok()) << lenient.status();
  EXPECT_EQ(lenient->streaming.jpeg_quality, MapClientOptions{}.jpeg_quality);
  auto strict = Load(path, /*strict=*/true);
  ASSERT_FALSE(strict.ok());
  EXPECT_NE(strict.status().message().find(path + ":3: unknown key 'jpg_quality' in 'streaming'"),
            std::string::npos)
      << strict.status();
}

TEST_F(ClientConfigTest, IllTypedValueNamesFileAndKey) {
  const std::string path = Write("client.yaml", "streaming:\n  max_unacked: many\n");
  auto c = Load(path, /*strict=*/false);
  ASSERT_EQ(c.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(c.status().message().find(path), std::string::npos) << c.status();
  EXPECT_NE(c.status().message().find("max_unacked"), std::string::npos) << c.status();
}

TEST_F(ClientConfigTest, GivenFileMustExistAndParse) {
  EXPECT_EQ(Load((dir_ / "absent.yaml").string(), false).status().code(),
            absl::StatusCode::kNotFound);
  EXPECT_FALSE(Load(Write("broken.yaml", "tracker: [1, 2\n"), false).ok());
}

TEST_F(ClientConfigTest, SequenceCameraWithKeysAtTheTopLevel) {
  Write("seq/camera.yaml",
        "fx: 500.0\nfy: 501.0\ncx: 320.0\ncy: 240.0\nwidth: 640\nheight: 480\ndepth_scale: 1000.0\n");
  auto c = Load("", /*strict=*/true);  // depth_scale is not an unknown camera key
  ASSERT_TRUE(c.ok()) << c.status();
  EXPECT_DOUBLE_EQ(c->tracker.camera.fx, 500.0);
  EXPECT_DOUBLE_EQ(c->tracker.depth_scale, 1000.0);
}

TEST_F(ClientConfigTest, SequenceCameraMisspeltKeyFailsWhenStrict) {
  const std::string camera = Write(
      "seq/camera.yaml", "camera:\n  preset: tum_fr2\ndepth_scal: 1000.0\n");
  auto lenient = Load("", /*strict=*/false);
  ASSERT_TRUE(lenient.ok()) << lenient.status();
  EXPECT_DOUBLE_EQ(lenient->tracker.camera.fx, PinholeCamera::TumFr2().fx);
  EXPECT_DOUBLE_EQ(lenient->tracker.depth_scale, TrackerOptions{}.depth_scale);
  auto strict = Load("", /*strict=*/true);
  ASSERT_FALSE(strict.ok());
  EXPECT_NE(strict.status().message().find(camera + ":3: unknown key 'depth_scal'"),
            std::string::npos)
      << strict.status();
}

TEST_F(ClientConfigTest, FolderWithoutCameraYamlTakesTheKinectItsTumNameGives) {
  // A sequence as TUM publishes it has no camera.yaml; its name says which Kinect took it.
  for (const auto& [name, preset] : std::vector<std::pair<std::string, std::string>>{
           {"rgbd_dataset_freiburg3_long_office_household", "tum_fr3"},
           {"tum_fr2_desk", "tum_fr2"},
           {"rgbd_dataset_freiburg1_rpy", "tum_fr1"}}) {
    std::filesystem::create_directories(dir_ / name);
    auto c = LoadClientConfig("", (dir_ / name).string() + "/");
    ASSERT_TRUE(c.ok()) << c.status();
    auto expected = CameraPreset(preset);
    ASSERT_TRUE(expected.ok());
    EXPECT_DOUBLE_EQ(c->tracker.camera.fx, expected->intrinsics.fx) << name;
    EXPECT_DOUBLE_EQ(c->tracker.distortion.k1, expected->distortion.k1) << name;
  }
  // fr3 images are published undistorted: no fr1 distortion is applied to them.
  auto fr3 = LoadClientConfig("", (dir_ / "rgbd_dataset_freiburg3_long_office_household").string());
  ASSERT_TRUE(fr3.ok());
  EXPECT_TRUE(fr3->tracker.distortion.IsZero());
}

TEST_F(ClientConfigTest, FolderCameraYieldsToCameraYamlAndToTheConfig) {
  std::filesystem::create_directories(dir_ / "tum_fr3_office");
  // The client config names a camera: the folder's name does not override it.
  const std::string path = Write("client.yaml", "tracker:\n  camera: tum_fr2\n");
  auto configured = LoadClientConfig(path, (dir_ / "tum_fr3_office").string());
  ASSERT_TRUE(configured.ok()) << configured.status();
  EXPECT_DOUBLE_EQ(configured->tracker.camera.fx, PinholeCamera::TumFr2().fx);
  // A camera.yaml in the folder wins over its name.
  Write("tum_fr3_office/camera.yaml", "camera: tum_fr1\n");
  auto from_yaml = LoadClientConfig("", (dir_ / "tum_fr3_office").string());
  ASSERT_TRUE(from_yaml.ok()) << from_yaml.status();
  EXPECT_DOUBLE_EQ(from_yaml->tracker.camera.fx, PinholeCamera::TumFr1().fx);
  // A name that says nothing keeps the configured default.
  EXPECT_EQ(TumCameraPresetForFolder("/data/office_walk"), "");
  EXPECT_EQ(TumCameraPresetForFolder("/data/freiburg12_x"), "");
  EXPECT_EQ(TumCameraPresetForFolder("/data/frame_dump"), "");
}

TEST(ShippedClientConfig, HasNoUnknownKeys) {
  SetStrictConfig(true);
  auto c = LoadClientConfig(SourceDir() + "/config/client.yaml", "/nonexistent");
  SetStrictConfig(false);
  ASSERT_TRUE(c.ok()) << c.status();
  EXPECT_EQ(c->streaming.max_unacked, 16);
}

}  // namespace
}  // namespace loci
