// Unknown keys in the server's YAML files: misspellings warn, or fail with strict checking; the
// shipped configuration files have none.
#include "server/runtime/server_options.h"

#include <gtest/gtest.h>

#include <fstream>
#include <limits>

#include "absl/strings/str_split.h"

#include "common/config.h"
#include "detection/detection_config.h"
#include "query/query_options.h"
#include "server/service/query_adapter.h"
#include "tests/support/temp_dir.h"

namespace loci::server {
namespace {

class ServerOptionsKeys : public loci::testing::TempDirTest {
 protected:
  void TearDown() override {
    SetStrictConfig(false);
    TempDirTest::TearDown();
  }
  std::string Write(const std::string& text) {
    std::ofstream(Path("server.yaml")) << text;
    return Path("server.yaml");
  }
};

TEST_F(ServerOptionsKeys, MisspeltKeysWarnOrFailWithFileAndKey) {
  const std::string path = Write(
      "server:\n  queue_capacity: 8\n  max_detection: 5\n"
      "detector:\n  enabled: false\n  score_threshold: 0.3\n"
      "map:\n  fusion:\n    merge_centroid: 0.2\n"
      "sessions:\n  robot2:\n    t_map_odom: [1, 0, 0]\n");
  ServerOptions lenient;
  ASSERT_TRUE(lenient.FromYamlFile(path).ok());
  EXPECT_EQ(lenient.queue_capacity, 8);              // the known keys still apply
  EXPECT_FALSE(lenient.detector_config["enabled"]);  // the detector gets only its own keys

  SetStrictConfig(true);
  ServerOptions strict;
  const Status s = strict.FromYamlFile(path);
  ASSERT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find(path + ":3: unknown key 'max_detection' in 'server'"),
            std::string::npos)
      << s;
  // The first section with an unknown key fails; the map and sessions sections are checked too.
  ASSERT_TRUE(Write("map:\n  fusion:\n    merge_centroid: 0.2\n") == path);
  const Status m = ServerOptions().FromYamlFile(path);
  EXPECT_NE(m.message().find("unknown key 'merge_centroid' in 'map.fusion'"), std::string::npos)
      << m;
  ASSERT_TRUE(Write("sessions:\n  robot2:\n    t_map_odom: [1, 0, 0]\n") == path);
  const Status r = ServerOptions().FromYamlFile(path);
  EXPECT_NE(r.message().find("unknown key 't_map_odom' in 'sessions.robot2'"), std::string::npos)
      << r;
}

TEST_F(ServerOptionsKeys, DetectorModeAndThreadsAreReadAndCheckedAndNotPassedToTheDetector) {
  ServerOptions o;
  ASSERT_TRUE(o.FromYamlFile(Write("detector:\n  enabled: true\n  mode: all\n  threads: 2\n"
                                   "  input_size_px: 640\n"))
                  .ok());
  EXPECT_EQ(o.detector_mode, "all");
  EXPECT_EQ(o.detector_threads, 2);
  EXPECT_FALSE(o.detector_config["mode"]);
  EXPECT_EQ(o.detector_config["input_size_px"].as<int>(), 640);
  const Status mode = ServerOptions().FromYamlFile(Write("detector:\n  mode: sometimes\n"));
  EXPECT_NE(mode.message().find("sometimes"), std::string::npos) << mode;
  const Status threads = ServerOptions().FromYamlFile(Write("detector:\n  threads: 0\n"));
  EXPECT_NE(threads.message().find("detector.threads"), std::string::npos) << threads;
}

TEST_F(ServerOptionsKeys, ANonPositiveClassHeightFailsWithTheClassName) {
  MapOptions map;
  const Status s = map.ClassesFromYaml(YAML::Load("max_height_m:\n  cup: -0.1\n"));
  ASSERT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("max_height_m.cup"), std::string::npos) << s;
  EXPECT_FALSE(map.ClassesFromYaml(YAML::Load("max_height_m: [0.1]\n")).ok());
}

TEST_F(ServerOptionsKeys, ClassStandsReplaceTheBuiltInOnesAndReachTheQuery) {
  ServerOptions shipped;  // config/classes.yaml of the repository
  ASSERT_TRUE(shipped.LoadClasses().ok());
  const std::map<std::string, double> tv = {{"tv", 0.25}};
  EXPECT_EQ(shipped.map.stand_m, tv);
  MapOptions map;
  ASSERT_TRUE(map.ClassesFromYaml(YAML::Load("stand_m: {potted plant: 0.1, tv: 0}\n")).ok());
  const std::map<std::string, double> given = {{"potted plant", 0.1}, {"tv", 0.0}};
  EXPECT_EQ(map.stand_m, given);  // tv 0: the built-in stand is off
  QueryAdapterOptions query;
  UseMapClassPriors(map, &query);
  EXPECT_EQ(query.query.relations.on_stand_m, given);
  for (const char* bad : {"stand_m: {tv: -0.1}\n", "stand_m: {tv: 2.5}\n", "stand_m: [tv]\n"}) {
    const Status s = MapOptions().ClassesFromYaml(YAML::Load(bad));
    ASSERT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << bad;
    EXPECT_NE(s.message().find("stand_m"), std::string::npos) << s;
  }
}

TEST_F(ServerOptionsKeys, TheBottomQuantileIsReadAndOneOfHalfOrMoreIsRefused) {
  MapOptions map;
  ASSERT_TRUE(map.FromYaml(YAML::Load("fusion:\n  bottom_quantile: 0.1\n")).ok());
  EXPECT_DOUBLE_EQ(map.fusion.bottom_quantile, 0.1);
  EXPECT_TRUE(map.Validate().ok());
  const Status s = MapOptions().FromYaml(YAML::Load("fusion:\n  bottom_quantile: 0.5\n"));
  ASSERT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("fusion.bottom_quantile"), std::string::npos) << s;
}

TEST_F(ServerOptionsKeys, TheShippedMapOptionsAreTheLibraryDefaults) {
  ServerOptions shipped;
  ASSERT_TRUE(shipped.FromYamlFile(SourceDir() + "/config/server.yaml").ok());
  ServerOptions library;  // the defaults, with the class lists of the shipped classes file
  ASSERT_TRUE(library.LoadClasses().ok());
  EXPECT_EQ(shipped.map.ValuesYaml(), library.map.ValuesYaml());
  EXPECT_LE(MapOptions::OptionCount(), 80u);
  // Every key has its doc line.
  const std::vector<std::string> lines = absl::StrSplit(MapOptions::DefaultsYaml(), '\n');
  for (const std::string& line : lines) {
    if (line.find(": ") == std::string::npos) continue;
    EXPECT_NE(line.find("  # "), std::string::npos) << line;
  }
}

TEST_F(ServerOptionsKeys, AMapOptionOutsideItsBoundsIsRefusedByName) {
  const Status s = MapOptions().FromYaml(YAML::Load("fusion:\n  p_detect: 1.5\n"));
  ASSERT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("map.fusion.p_detect"), std::string::npos) << s;
  const Status t =
      MapOptions().FromYaml(YAML::Load("observation:\n  support_tops:\n    cell_m: 0\n"));
  EXPECT_NE(t.message().find("map.observation.support_tops.cell_m"), std::string::npos) << t;
  SetStrictConfig(true);
  EXPECT_FALSE(MapOptions().FromYaml(YAML::Load("fusion:\n  straddle_share: 0.25\n")).ok());
}

TEST_F(ServerOptionsKeys, ShippedConfigFilesHaveNoUnknownKeys) {
  SetStrictConfig(true);
  const std::string config = SourceDir() + "/config/";
  ServerOptions server;
  EXPECT_TRUE(server.FromYamlFile(config + "server.yaml").ok());
  // config/classes.yaml's size priors are read: a laptop is no taller than 0.45 m; furniture has
  // no height limit.
  EXPECT_DOUBLE_EQ(server.map.MaxHeightM("laptop"), 0.45);
  EXPECT_EQ(server.map.MaxHeightM("dining table"), std::numeric_limits<double>::infinity());
  EXPECT_DOUBLE_EQ(server.map.MaxSizeM("laptop"), 0.6);
  EXPECT_TRUE(query::LoadQueryOptions(config + "query.yaml").ok());
  const auto detection = detection::LoadDetectionConfig(config + "detection.yaml");
  EXPECT_TRUE(detection.ok()) << detection.status();
}

}  // namespace
}  // namespace loci::server
