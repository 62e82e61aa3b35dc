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

TEST(ShippedClientConfig, HasNoUnknownKeys) {
  SetStrictConfig(true);
  auto c = LoadClientConfig(SourceDir() + "/config/client.yaml", "/nonexistent");
  SetStrictConfig(false);
  ASSERT_TRUE(c.ok()) << c.status();
  EXPECT_EQ(c->streaming.max_unacked, 16);
}

}  // namespace
}  // namespace loci
