// The map's file exports: the binary PLY read back byte by byte, and the objects JSON read back
// with ReadObjectsJson (it is a superset of objects.json) and as plain JSON.
#include "server/map/map_export.h"

#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>

#include "common/objects_json.h"
#include "tests/support/temp_dir.h"

namespace loci::server {
namespace {

using MapExport = loci::testing::TempDirTest;

std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST_F(MapExport, PlyHeaderAndBinaryRecords) {
  const std::vector<SemanticPoint> points{{Eigen::Vector3f(1.5f, -2.0f, 0.25f), 0x102030, 7},
                                          {Eigen::Vector3f(0, 0, 0), 0xffffff, 0}};
  ASSERT_TRUE(WritePly(Path("cloud.ply"), points).ok());
  const std::string bytes = ReadAll(Path("cloud.ply"));
  const std::string end = "end_header\n";
  const size_t body = bytes.find(end);
  ASSERT_NE(body, std::string::npos);
  const std::string header = bytes.substr(0, body + end.size());
  EXPECT_EQ(header.rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u);
  EXPECT_NE(header.find("element vertex 2\n"), std::string::npos);
  EXPECT_NE(header.find("property int object_id\n"), std::string::npos);
  ASSERT_EQ(bytes.size() - header.size(), 2 * 19u);  // 3 floats, 3 uchar, 1 int per point
  const char* rec = bytes.data() + header.size();
  float xyz[3];
  std::memcpy(xyz, rec, 12);
  EXPECT_FLOAT_EQ(xyz[0], 1.5f);
  EXPECT_FLOAT_EQ(xyz[1], -2.0f);
  EXPECT_FLOAT_EQ(xyz[2], 0.25f);
  EXPECT_EQ(static_cast<uint8_t>(rec[12]), 0x10);
  EXPECT_EQ(static_cast<uint8_t>(rec[13]), 0x20);
  EXPECT_EQ(static_cast<uint8_t>(rec[14]), 0x30);
  int32_t id = 0;
  std::memcpy(&id, rec + 15, 4);
  EXPECT_EQ(id, 7);
}

TEST_F(MapExport, ObjectsJsonReadsBackAsObjectsJson) {
  MapObject cup;
  cup.id = 3;
  cup.class_name = "cup";
  cup.confidence = 0.8;
  cup.labels = {{"cup", 0.8}, {"bowl", 0.2}};
  cup.centroid_m = {1, 2, 0.8};
  cup.aabb_min_m = {0.95, 1.95, 0.75};
  cup.aabb_max_m = {1.05, 2.05, 0.87};
  cup.robots = {"r1", "r2"};
  cup.observation_count = 5;
  cup.missed_views = 7;
  cup.existence = 0.97;
  cup.confirmed = true;
  ASSERT_TRUE(WriteObjectsJsonExport(Path("objects.json"), {cup}, Vec3d::UnitZ()).ok());

  auto scene = ReadObjectsJson(Path("objects.json"));
  ASSERT_TRUE(scene.ok()) << scene.status();
  EXPECT_TRUE(scene->up.isApprox(Vec3d::UnitZ()));
  ASSERT_EQ(scene->objects.size(), 1u);
  const GroundTruthObject& o = scene->objects[0];
  EXPECT_EQ(o.id, 3);
  EXPECT_EQ(o.class_name, "cup");
  EXPECT_TRUE(o.centroid_m.isApprox(cup.centroid_m));
  EXPECT_TRUE(o.extent_m.isApprox(Eigen::Vector3d(0.1, 0.1, 0.12)));
  EXPECT_EQ(o.on_id, 0);

  const auto j = nlohmann::json::parse(ReadAll(Path("objects.json")));
  EXPECT_EQ(j["frame"], "map");
  const auto& e = j["objects"][0];
  EXPECT_DOUBLE_EQ(e["labels"]["bowl"].get<double>(), 0.2);
  EXPECT_EQ(e["robots"], nlohmann::json::array({"r1", "r2"}));
  EXPECT_EQ(e["observation_count"], 5);
  EXPECT_EQ(e["missed_views"], 7);
  EXPECT_DOUBLE_EQ(e["existence"].get<double>(), 0.97);
  EXPECT_EQ(e["confirmed"], true);
  EXPECT_EQ(e["obb"]["q_map_box_wxyz"], nlohmann::json::array({1.0, 0.0, 0.0, 0.0}));
}

TEST_F(MapExport, UnwritablePathIsAnError) {
  EXPECT_FALSE(WritePly(Path("missing/dir/cloud.ply"), {}).ok());
  EXPECT_FALSE(WriteObjectsJsonExport(Path("missing/dir/o.json"), {}, Vec3d::UnitZ()).ok());
}

}  // namespace
}  // namespace loci::server
