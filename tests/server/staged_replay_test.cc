// The server's stages (ingest gate, mapping worker, alignment and pose-graph stages,
// checkpointer, publisher) change nothing in the map: a `loci synth` scene streamed over
// loopback gRPC gives the same map, object by object, as the plain replay of the keyframes the
// server stored (LoadMap without a checkpoint, the path of `loci eval objects` and `loci
// reprocess`). Loop closure is off: it moves keyframes by timing-dependent solves.
#include <grpcpp/create_channel.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "server/runtime/map_server.h"
#include "server/runtime/replay.h"
#include "server/service/grpc_server.h"
#include "server/storage/sqlite_store.h"
#include "synth/scene.h"
#include "synth/sequence_writer.h"
#include "tests/server/grpc_stream.h"
#include "tests/server/scene_stream.h"

namespace loci::server {
namespace {

namespace fs = std::filesystem;

struct MapFigures {
  std::vector<MapObject> objects;  // confirmed and candidates, in id order
  std::vector<Mapper::KeyframePoseUpdate> poses;
  uint64_t cloud_points = 0;
};

MapFigures FiguresOf(const Mapper& mapper) {
  return {mapper.Snapshot(false), mapper.KeyframePoses(), mapper.Stats().cloud_points};
}

void ExpectSameMap(const MapFigures& live, const MapFigures& replayed) {
  ASSERT_EQ(live.objects.size(), replayed.objects.size());
  for (size_t i = 0; i < live.objects.size(); ++i) {
    const MapObject& a = live.objects[i];
    const MapObject& b = replayed.objects[i];
    EXPECT_EQ(a.id, b.id);
    EXPECT_EQ(a.class_name, b.class_name) << a.id;
    EXPECT_EQ(a.confirmed, b.confirmed) << a.id;
    EXPECT_EQ(a.observation_count, b.observation_count) << a.id;
    EXPECT_EQ(a.missed_views, b.missed_views) << a.id;
    EXPECT_LT((a.centroid_m - b.centroid_m).norm(), 1e-9) << a.id;
    EXPECT_LT((a.aabb_max_m - b.aabb_max_m).norm(), 1e-9) << a.id;
  }
  ASSERT_EQ(live.poses.size(), replayed.poses.size());
  for (size_t i = 0; i < live.poses.size(); ++i) {
    EXPECT_EQ(live.poses[i].keyframe_id, replayed.poses[i].keyframe_id);
    EXPECT_TRUE(live.poses[i].T_base_kf.isApprox(replayed.poses[i].T_base_kf, 1e-12));
  }
  EXPECT_EQ(live.cloud_points, replayed.cloud_points);
}

TEST(StagedServer, StreamedMapEqualsTheReplayOfItsStoredKeyframes) {
  const std::string dir = ::testing::TempDir() + "/loci_staged_" + std::to_string(getpid());
  fs::remove_all(dir);
  fs::create_directories(dir);
  synth::SceneOptions scene;
  scene.seed = 2;
  scene.num_frames = 45;
  scene.fps_hz = 5.0;
  scene.num_objects = 8;
  ASSERT_TRUE(synth::WriteSequence(scene, dir + "/scene").ok());
  auto keyframes = testing::LoadSceneKeyframes(dir + "/scene");
  ASSERT_TRUE(keyframes.ok()) << keyframes.status();
  std::ofstream(dir + "/server.yaml")
      << "map:\n  cloud:\n    max_depth_m: 6.0\n  octomap:\n    max_range_m: 6.0\n"
      << "align:\n  loops:\n    enabled: false\n";
  ServerOptions options;
  ASSERT_TRUE(options.FromYamlFile(dir + "/server.yaml").ok());
  options.db_path = dir + "/map.db";

  MapFigures live;
  {
    auto server = MapServer::Open(options);
    ASSERT_TRUE(server.ok()) << server.status();
    auto grpc_server = GrpcServer::Start(server->get(), "127.0.0.1:0", 64);
    ASSERT_TRUE(grpc_server.ok()) << grpc_server.status();
    auto channel = grpc::CreateChannel(absl::StrCat("127.0.0.1:", (*grpc_server)->port()),
                                       grpc::InsecureChannelCredentials());
    auto mapping = loci::v1::Mapping::NewStub(channel);
    const std::string session = testing::OpenSessionOn(mapping.get(), "robot1", false);
    const int n = static_cast<int>(keyframes->size());
    ASSERT_EQ(static_cast<int>(testing::StreamAcked(mapping.get(), session, *keyframes, 0, n).size()),
              n);
    (*server)->Flush();
    live = FiguresOf((*server)->mapper());
    grpc_server->reset();
  }
  ASSERT_EQ(live.poses.size(), keyframes->size());
  size_t confirmed = 0;
  for (const MapObject& o : live.objects) confirmed += o.confirmed;
  ASSERT_GE(confirmed, 5u) << "too few objects for the comparison to mean anything";

  auto store = SqliteStore::Open(options.db_path);
  ASSERT_TRUE(store.ok()) << store.status();
  auto replayed = std::make_unique<Mapper>(options.map);
  LoadOptions load;
  load.use_checkpoint = false;
  load.store_products = false;
  auto report = LoadMap(**store, &replayed, nullptr, load);
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_EQ(report->from_products, keyframes->size());
  ExpectSameMap(live, FiguresOf(*replayed));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace loci::server
