// Map islands on loopback gRPC: robot A maps one `loci synth` room (the shared map),
// robot B another room with its own odometry. B is never aligned, and its keyframes are mapped
// in an island of its own: its objects are as exact as a single robot's map (count error 0,
// centroids within 2 cm, in B's own frame), FindObjects and GetObject give them with their
// island, GetStats lists the island, Ask names it, it equals the map B makes alone, and a
// restart re-derives it. Robot C then
// starts in A's room with its own odometry: it is aligned, and its island is gone. An island is
// also brought in by an aligned robot that sees its places.
#include <grpcpp/create_channel.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <set>
#include <tuple>
#include <utility>

#include "common/objects_json.h"
#include "loci/v1/mapping.grpc.pb.h"
#include "loci/v1/query.grpc.pb.h"
#include "proto/convert.h"
#include "server/http/http_api.h"
#include "server/map/object_eval.h"
#include "server/service/grpc_server.h"
#include "server/runtime/map_server.h"
#include "server/runtime/proto_convert.h"
#include "server/service/query_adapter.h"
#include "server/storage/sqlite_store.h"
#include "synth/sequence_writer.h"
#include "tests/server/keyframe_proto.h"
#include "tests/server/island_robots.h"
#include "tests/server/scene_stream.h"
// Last: httplib pulls <resolv.h>, whose `_res` macro breaks Eigen headers included after it.
#include <httplib.h>

namespace loci::server {
namespace {

using testing::Rebased;
using testing::Room;
using testing::Running;
using testing::SessionsByRobot;
using testing::Start;
using testing::Stats;
using testing::Stream;
using testing::StreamInto;

namespace fs = std::filesystem;

std::vector<loci::v1::Object> Find(loci::v1::Query::Stub* stub, bool include_islands) {
  grpc::ClientContext ctx;
  loci::v1::FindObjectsRequest req;
  req.set_confirmed_only(true);
  req.set_include_islands(include_islands);
  loci::v1::FindObjectsResponse resp;
  EXPECT_TRUE(stub->FindObjects(&ctx, req, &resp).ok());
  return {resp.objects().begin(), resp.objects().end()};
}

std::pair<grpc::Status, loci::v1::GetOctomapResponse> Octomap(loci::v1::Query::Stub* stub,
                                                              const std::string& island) {
  grpc::ClientContext ctx;
  loci::v1::GetOctomapRequest req;
  req.set_island(island);
  loci::v1::GetOctomapResponse resp;
  const grpc::Status status = stub->GetOctomap(&ctx, req, &resp);
  return {status, resp};
}

std::vector<loci::v1::Object> InIsland(const std::vector<loci::v1::Object>& objects,
                                       const std::string& island) {
  std::vector<loci::v1::Object> out;
  for (const auto& o : objects) {
    if (o.island() == island) out.push_back(o);
  }
  return out;
}

class Islands : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = ::testing::TempDir() + "/loci_islands_" + std::to_string(getpid());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    for (const auto& [name, seed] : {std::pair<std::string, uint64_t>{"a", 2}, {"b", 1}}) {
      ASSERT_TRUE(synth::WriteSequence(Room(seed), dir_ + "/" + name).ok());
      auto views = testing::LoadSceneKeyframes(dir_ + "/" + name);
      ASSERT_TRUE(views.ok()) << views.status();
      views_[name] = std::move(*views);
    }
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(dir_);
  }

  // B's island objects against room b's truth (objects detected in >= 3 keyframes), in room
  // b's world: T_world_island = T_world_odomB * T_island_odomB^-1. Centroids within 4 cm: an
  // object the camera sees from part of a circle keeps only the voxels a quarter of its views
  // saw (the shape's support rule), so its far side is short (measured: up to 3.5 cm).
  void ExpectExact(const std::vector<loci::v1::Object>& island_objects,
                   const SE3d& T_island_odom, const ServerOptions& options,
                   double max_centroid_error_m = 0.04) {
    const SE3d T_world_odom = PoseFromProto(views_["b"][0].t_odom_cam());
    const SE3d T_world_island = T_world_odom * T_island_odom.inverse();
    std::vector<MapObject> objects;
    for (const auto& o : island_objects) objects.push_back(Transformed(FromProto(o), T_world_island));
    auto gt = ReadObjectsJson(dir_ + "/b/objects.json");
    ASSERT_TRUE(gt.ok());
    std::map<int64_t, int> detected_in;
    for (const auto& kf : views_["b"]) {
      for (const auto& d : kf.detections()) ++detected_in[d.track_id()];
    }
    std::erase_if(gt->objects, [&](const GroundTruthObject& o) { return detected_in[o.id] < 3; });
    ObjectEvalOptions eo;
    for (const auto& c : options.map.mapped_classes) {
      if (!options.map.IsDynamic(c)) eo.classes.push_back(c);
    }
    const ObjectEvalResult r = EvaluateObjects(objects, *gt, eo);
    EXPECT_GE(r.gt_count, 4);
    EXPECT_EQ(r.count_error, 0.0) << "island " << r.detected_count << ", truth " << r.gt_count;
    EXPECT_TRUE(r.missed_gt_ids.empty());
    EXPECT_TRUE(r.false_positive_ids.empty());
    for (const ObjectMatch& m : r.matches) {
      EXPECT_LT(m.centroid_error_m, max_centroid_error_m)
          << m.class_name << " (gt " << m.gt_id << ")";
    }
  }

  std::string dir_;
  std::map<std::string, std::vector<loci::v1::Keyframe>> views_;
};

// Loop closure off throughout: the island is compared with the map B makes alone and with
// itself after a restart, exactly (an island's own loop closure: island_loops_test.cc).
TEST_F(Islands, UnalignedRobotGetsAnExactIslandMapThatAlignmentDissolves) {
  const std::string db = dir_ + "/islands.db";
  std::string island;
  int64_t island_first_id = 0;
  std::vector<loci::v1::Object> before_restart;
  loci::v1::GetOctomapResponse island_octomap;
  {
    Running r = Start(db, /*loops=*/false);
    ASSERT_TRUE(r.server);
    Stream(r.mapping.get(), "A", Rebased(views_["a"], 0, false));
    island = Stream(r.mapping.get(), "B", Rebased(views_["b"], 0, true));
    r.server->Flush();

    const auto sessions = SessionsByRobot(Stats(r.query.get()));
    ASSERT_TRUE(sessions.count("B"));
    const loci::v1::SessionAlignment* b = &sessions.at("B");
    ASSERT_FALSE(b->aligned()) << "room b is another place: B must stay an island";
    const std::vector<loci::v1::Object> shared = Find(r.query.get(), false);
    const std::vector<loci::v1::Object> all = Find(r.query.get(), true);
    for (const auto& o : shared) EXPECT_EQ(o.island(), "") << o.id();
    before_restart = InIsland(all, island);
    ASSERT_EQ(all.size(), shared.size() + before_restart.size());
    EXPECT_EQ(b->island_objects(), before_restart.size());
    for (const auto& o : before_restart) EXPECT_GT(o.id(), kIslandIdStride);
    island_first_id = (before_restart.front().id() - 1) / kIslandIdStride * kIslandIdStride + 1;
    ExpectExact(before_restart, PoseFromProto(b->t_island_odom()), r.server->options());

    // GetObject by an island id; Ask names the island for a class only room b holds.
    {
      grpc::ClientContext ctx;
      loci::v1::GetObjectRequest req;
      req.set_id(before_restart.front().id());
      loci::v1::GetObjectResponse resp;
      ASSERT_TRUE(r.query->GetObject(&ctx, req, &resp).ok());
      EXPECT_EQ(resp.object().island(), island);
      EXPECT_FALSE(resp.keyframe_ids().empty());
    }
    std::set<std::string> shared_classes;
    for (const auto& o : shared) shared_classes.insert(o.class_name());
    const auto only_b = std::find_if(before_restart.begin(), before_restart.end(), [&](const auto& o) {
      return !shared_classes.count(o.class_name());
    });
    ASSERT_NE(only_b, before_restart.end()) << "rooms a and b hold the same classes";
    grpc::ClientContext ctx;
    loci::v1::AskRequest ask;
    ask.set_text("where is the " + only_b->class_name());
    loci::v1::AskResponse answer;
    ASSERT_TRUE(r.query->Ask(&ctx, ask, &answer).ok());
    std::printf("  %s? %s\n", ask.text().c_str(), answer.answer().c_str());
    // HTTP gives the same objects, islands only when asked for.
    auto http = HttpApi::Start(r.grpc->query_service(), "127.0.0.1:0");
    ASSERT_TRUE(http.ok()) << http.status();
    httplib::Client client("127.0.0.1", (*http)->port());
    const auto with = client.Get("/api/objects?confirmed_only=1&include_islands=1");
    const auto without = client.Get("/api/objects?confirmed_only=1");
    ASSERT_TRUE(with && without);
    EXPECT_EQ(with->status, 200);
    EXPECT_NE(with->body.find(island), std::string::npos);
    EXPECT_EQ(without->body.find(island), std::string::npos);
    EXPECT_EQ(client.Get("/api/objects?include_islands=maybe")->status, 400);
    EXPECT_NE(answer.answer().find("In the island of robot B (" + island), std::string::npos)
        << answer.answer();
    ASSERT_FALSE(answer.objects().empty()) << answer.answer();
    EXPECT_EQ(answer.objects(0).island(), island) << answer.answer();
    // The island's own OctoMap; an unknown island is NOT_FOUND.
    grpc::Status status;
    std::tie(status, island_octomap) = Octomap(r.query.get(), island);
    ASSERT_TRUE(status.ok()) << status.error_message();
    EXPECT_GT(island_octomap.node_count(), 1000u);
    EXPECT_NE(island_octomap.octomap_bt(), Octomap(r.query.get(), "").second.octomap_bt());
    EXPECT_EQ(Octomap(r.query.get(), "no-such-island").first.error_code(),
              grpc::StatusCode::NOT_FOUND);
  }
  {  // The island is the map B makes alone: the same objects in the same frame.
    Running solo = Start(dir_ + "/solo.db", /*loops=*/false);
    ASSERT_TRUE(solo.server);
    Stream(solo.mapping.get(), "B", Rebased(views_["b"], 0, true));
    solo.server->Flush();
    const std::vector<loci::v1::Object> alone = Find(solo.query.get(), false);
    ASSERT_EQ(alone.size(), before_restart.size());
    for (size_t i = 0; i < alone.size(); ++i) {
      EXPECT_EQ(alone[i].class_name(), before_restart[i].class_name());
      EXPECT_EQ(alone[i].id() + island_first_id - 1, before_restart[i].id());
      EXPECT_NEAR(alone[i].centroid_m().x(), before_restart[i].centroid_m().x(), 1e-3);
      EXPECT_NEAR(alone[i].centroid_m().y(), before_restart[i].centroid_m().y(), 1e-3);
      EXPECT_NEAR(alone[i].centroid_m().z(), before_restart[i].centroid_m().z(), 1e-3);
    }
    // ... and the same OctoMap (occupied and free cells at the same places).
    const loci::v1::GetOctomapResponse solo_octomap = Octomap(solo.query.get(), "").second;
    EXPECT_EQ(island_octomap.node_count(), solo_octomap.node_count());
    EXPECT_EQ(island_octomap.octomap_bt(), solo_octomap.octomap_bt());
  }
  // A restart re-derives the island from the stored products: the same objects.
  Running r = Start(db, /*loops=*/false);
  ASSERT_TRUE(r.server);
  const std::vector<loci::v1::Object> after = InIsland(Find(r.query.get(), true), island);
  ASSERT_EQ(after.size(), before_restart.size());
  for (size_t i = 0; i < after.size(); ++i) {
    EXPECT_EQ(after[i].id(), before_restart[i].id());
    EXPECT_EQ(after[i].class_name(), before_restart[i].class_name());
    EXPECT_NEAR(after[i].centroid_m().x(), before_restart[i].centroid_m().x(), 1e-3);
    EXPECT_NEAR(after[i].centroid_m().z(), before_restart[i].centroid_m().z(), 1e-3);
  }
  // C starts in A's room, elsewhere, with its own odometry: aligned, and no island of C stays.
  // Watchers saw C's island objects come and go.
  auto events = std::make_shared<ObjectEventQueue>(100000);
  ASSERT_TRUE(r.server->events().Subscribe(events).ok());
  const std::string c = Stream(r.mapping.get(), "C", Rebased(views_["a"], 20, true));
  r.server->Flush();
  r.server->events().Unsubscribe(events);
  events->Close();
  std::set<int64_t> created, removed;
  while (std::optional<ObjectEventOut> e = events->Pop()) {
    if (e->object.island != c) continue;
    if (e->kind == ObjectChange::Kind::kCreated) created.insert(e->object.id);
    if (e->kind == ObjectChange::Kind::kRemoved) removed.insert(e->object.id);
  }
  EXPECT_FALSE(created.empty()) << "C's first keyframes were mapped in an island";
  for (int64_t id : created) EXPECT_TRUE(removed.count(id)) << id;
  const auto sessions = SessionsByRobot(Stats(r.query.get()));
  ASSERT_TRUE(sessions.count("C"));
  EXPECT_TRUE(sessions.at("C").aligned());
  const std::vector<loci::v1::Object> all = Find(r.query.get(), true);
  EXPECT_TRUE(InIsland(all, c).empty());
  EXPECT_EQ(InIsland(all, island).size(), before_restart.size());
}

// Robots B and C both start in room b, which the shared map (A, room a) has never seen; C starts
// at view 20 with its own odometry. Their islands overlap, so C's joins B's (within 2 cm and
// 1.5 deg of the truth): one island holds room b's objects once (count error 0, centroids within
// 3 cm of the truth), and the join survives a restart.
TEST_F(Islands, OverlappingIslandsJoinIntoOne) {
  const std::string db = dir_ + "/join.db";
  std::string b, c;
  size_t joined_objects = 0;
  {
    Running r = Start(db);
    ASSERT_TRUE(r.server);
    Stream(r.mapping.get(), "A", Rebased(views_["a"], 0, false));
    b = Stream(r.mapping.get(), "B", Rebased(views_["b"], 0, true));
    c = Stream(r.mapping.get(), "C", Rebased(views_["b"], 20, true));
    r.server->Flush();
    const auto sessions = SessionsByRobot(Stats(r.query.get()));
    ASSERT_TRUE(sessions.count("B") && sessions.count("C"));
    EXPECT_FALSE(sessions.at("B").aligned());
    EXPECT_FALSE(sessions.at("C").aligned());
    EXPECT_EQ(sessions.at("B").island(), b);
    EXPECT_EQ(sessions.at("C").island(), b) << "C's island did not join B's";
    const std::vector<loci::v1::Object> all = Find(r.query.get(), true);
    EXPECT_TRUE(InIsland(all, c).empty());
    const std::vector<loci::v1::Object> island = InIsland(all, b);
    EXPECT_EQ(sessions.at("C").island_objects(), island.size());
    // Where the join put C's odometry frame in B's, against the truth (both start at a view's
    // true pose); objects fused from both then carry that error too (3 cm, as a merge into the
    // shared map is held to in ThreeRobots).
    const SE3d T_b_c = PoseFromProto(sessions.at("B").t_island_odom()).inverse() *
                       PoseFromProto(sessions.at("C").t_island_odom());
    const SE3d T_b_c_true = PoseFromProto(views_["b"][0].t_odom_cam()).inverse() *
                            PoseFromProto(views_["b"][20].t_odom_cam());
    const SE3d T_err = T_b_c_true.inverse() * T_b_c;
    const double err_deg = Eigen::AngleAxisd(T_err.linear()).angle() * 180 / M_PI;
    std::printf("  C joined B's island %.1f mm, %.2f deg from the truth\n",
                1e3 * T_err.translation().norm(), err_deg);
    EXPECT_LT(T_err.translation().norm(), 0.02);
    EXPECT_LT(err_deg, 1.5);
    ExpectExact(island, PoseFromProto(sessions.at("B").t_island_odom()), r.server->options());
    int seen_by_both = 0;
    for (const auto& o : island) seen_by_both += o.robots_size() == 2;
    EXPECT_GT(seen_by_both, 0) << "no object fused from both robots' views";
    joined_objects = island.size();
  }
  Running r = Start(db);
  ASSERT_TRUE(r.server);
  const auto sessions = SessionsByRobot(Stats(r.query.get()));
  ASSERT_TRUE(sessions.count("C"));
  EXPECT_EQ(sessions.at("C").island(), b);
  EXPECT_EQ(InIsland(Find(r.query.get(), true), b).size(), joined_objects);
}

// An island whose robot has stopped streaming is brought in by an aligned robot: B maps room b
// (an island) and stops; then A, aligned, walks on from room a into room b, 6 m beside it and
// turned by 0.3 rad. A's keyframes there match B's island, which is aligned through them: B is
// placed within 3 cm and 1.5 deg of the truth, no island is left, and each object of room b is in
// the shared map once (what A and B both saw fused).
TEST_F(Islands, AnAlignedRobotThatSeesAnIslandsPlacesBringsItIn) {
  Running r = Start(dir_ + "/pull.db");
  ASSERT_TRUE(r.server);
  const std::string a = Stream(r.mapping.get(), "A", Rebased(views_["a"], 0, false));
  const std::string b = Stream(r.mapping.get(), "B", Rebased(views_["b"], 0, true));
  r.server->Flush();
  ASSERT_FALSE(SessionsByRobot(Stats(r.query.get())).at("B").aligned());
  const SE3d T_a_b =
      MakeSE3(Vec3d(6.0, 0.0, 0.0), Quatd(Eigen::AngleAxisd(0.3, Vec3d::UnitZ()))).inverse();
  std::vector<loci::v1::Keyframe> a_in_b;
  for (const loci::v1::Keyframe& view : views_["b"]) {
    loci::v1::Keyframe kf = view;
    kf.set_t_ns(kf.t_ns() + 100'000'000'000);
    ToProto(T_a_b * PoseFromProto(view.t_odom_cam()), kf.mutable_t_odom_cam());
    a_in_b.push_back(kf);
  }
  StreamInto(r.mapping.get(), a, a_in_b, static_cast<int64_t>(views_["a"].size()));
  r.server->Flush();
  const loci::v1::GetStatsResponse stats = Stats(r.query.get());
  const auto sessions = SessionsByRobot(stats);
  ASSERT_TRUE(sessions.at("B").aligned()) << "A saw room b, and B's island stayed out";
  EXPECT_GE(stats.alignment().islands_pulled(), 1u);
  EXPECT_EQ(sessions.at("B").aligned_after_keyframes(), views_["b"].size());
  const std::vector<loci::v1::Object> all = Find(r.query.get(), true);
  for (const auto& o : all) EXPECT_EQ(o.island(), "") << "island object #" << o.id() << " left";
  const SE3d T_map_a = PoseFromProto(sessions.at("A").t_map_odom());
  const SE3d T_map_odomB = PoseFromProto(sessions.at("B").t_map_odom());
  const SE3d T_map_b = T_map_a * T_a_b;  // room b's world in the map
  const SE3d T_err =
      (T_map_b * PoseFromProto(views_["b"][0].t_odom_cam())).inverse() * T_map_odomB;
  const double err_deg = Eigen::AngleAxisd(T_err.linear()).angle() * 180 / M_PI;
  std::printf("  B placed through A's keyframes %.1f mm, %.2f deg from the truth\n",
              1e3 * T_err.translation().norm(), err_deg);
  EXPECT_LT(T_err.translation().norm(), 0.03);  // 9.0 mm, 0.84 deg here
  EXPECT_LT(err_deg, 1.5);
  auto gt = ReadObjectsJson(dir_ + "/b/objects.json");
  ASSERT_TRUE(gt.ok());
  std::map<int64_t, int> detected_in;
  for (const auto& kf : views_["b"]) {
    for (const auto& d : kf.detections()) ++detected_in[d.track_id()];
  }
  int checked = 0;
  for (const GroundTruthObject& g : gt->objects) {
    if (detected_in[g.id] < 3 || g.dynamic) continue;
    int near = 0;
    for (const auto& o : all) {
      const Vec3d c_m(o.centroid_m().x(), o.centroid_m().y(), o.centroid_m().z());
      near += o.class_name() == g.class_name && (c_m - T_map_b * g.centroid_m).norm() < 0.05;
    }
    EXPECT_EQ(near, 1) << g.class_name << " (gt " << g.id << ") of room b";
    ++checked;
  }
  EXPECT_GE(checked, 4);
}

// An island aligns as a whole: B and C join in room b (as above); then C walks on into room a,
// which the shared map holds, 6 m beside room b and turned by 0.3 rad (T_b_a: room a's world in
// room b's). C is aligned there, and B with it through the join: no island is left; B sits
// where the join put it from C (5 cm, 1.5 deg: the pose graph moves both after the alignment),
// within 2 deg of the truth from A (its position error then grows with the 6 m lever arm), and
// every object of room b is in the shared map where B's placement puts it (5 cm).
TEST_F(Islands, AnIslandIsAlignedAsAWhole) {
  Running r = Start(dir_ + "/whole.db");
  ASSERT_TRUE(r.server);
  Stream(r.mapping.get(), "A", Rebased(views_["a"], 0, false));
  const std::string b = Stream(r.mapping.get(), "B", Rebased(views_["b"], 0, true));
  const SE3d T_b_a = MakeSE3(Vec3d(6.0, 0.0, 0.0), Quatd(Eigen::AngleAxisd(0.3, Vec3d::UnitZ())));
  const SE3d T_odomC_b = PoseFromProto(views_["b"][20].t_odom_cam()).inverse();
  std::vector<loci::v1::Keyframe> c_views = Rebased(views_["b"], 20, true);
  for (size_t i = 10; i < views_["a"].size(); ++i) {  // later in time, in room a
    loci::v1::Keyframe kf = views_["a"][i];
    kf.set_t_ns(kf.t_ns() + 100'000'000'000);
    ToProto(T_odomC_b * T_b_a * PoseFromProto(kf.t_odom_cam()), kf.mutable_t_odom_cam());
    c_views.push_back(kf);
  }
  Stream(r.mapping.get(), "C", c_views);
  r.server->Flush();
  const auto sessions = SessionsByRobot(Stats(r.query.get()));
  ASSERT_TRUE(sessions.count("A") && sessions.count("B") && sessions.count("C"));
  ASSERT_TRUE(sessions.at("C").aligned());
  ASSERT_TRUE(sessions.at("B").aligned()) << "B did not follow C, whose island it shares";
  const std::vector<loci::v1::Object> all = Find(r.query.get(), true);
  for (const auto& o : all) EXPECT_EQ(o.island(), "") << "island object #" << o.id() << " left";
  // A's odometry frame is room a's world; B's is room b's view 0, C's room b's view 20.
  const SE3d T_map_a = PoseFromProto(sessions.at("A").t_map_odom());
  const SE3d T_map_odomB = PoseFromProto(sessions.at("B").t_map_odom());
  const SE3d T_map_odomC = PoseFromProto(sessions.at("C").t_map_odom());
  auto error = [](const SE3d& truth, const SE3d& estimate) {
    const SE3d T_err = truth.inverse() * estimate;
    return std::pair<double, double>(T_err.translation().norm(),
                                     Eigen::AngleAxisd(T_err.linear()).angle() * 180 / M_PI);
  };
  // B against C, both placed in the map: the join's estimate, carried through C's alignment.
  const auto [bc_m, bc_deg] = error(PoseFromProto(views_["b"][20].t_odom_cam()).inverse() *
                                        PoseFromProto(views_["b"][0].t_odom_cam()),
                                    T_map_odomC.inverse() * T_map_odomB);
  // B against A: C's alignment in room a adds its own yaw error, times the 6 m lever arm.
  const auto [ab_m, ab_deg] = error(T_b_a.inverse() * PoseFromProto(views_["b"][0].t_odom_cam()),
                                    T_map_a.inverse() * T_map_odomB);
  std::printf("  B from C %.1f mm, %.2f deg; B from A %.1f mm, %.2f deg from the truth\n",
              1e3 * bc_m, bc_deg, 1e3 * ab_m, ab_deg);
  EXPECT_LT(bc_m, 0.05);  // 0.6 mm at the join; the pose graph then moves both (about 2 cm)
  EXPECT_LT(bc_deg, 1.5);
  EXPECT_LT(ab_deg, 2.0);
  EXPECT_LT(ab_m, 0.03 + 6.0 * ab_deg * M_PI / 180);
  // Room b's objects entered the shared map where B's placement puts them.
  auto gt = ReadObjectsJson(dir_ + "/b/objects.json");
  ASSERT_TRUE(gt.ok());
  std::map<int64_t, int> detected_in;
  for (const auto& kf : views_["b"]) {
    for (const auto& d : kf.detections()) ++detected_in[d.track_id()];
  }
  const SE3d T_map_b = T_map_odomB * PoseFromProto(views_["b"][0].t_odom_cam()).inverse();
  int checked = 0;
  double worst_m = 0;
  for (const GroundTruthObject& g : gt->objects) {
    if (detected_in[g.id] < 3 || g.dynamic) continue;
    double nearest_m = 1e9;
    for (const auto& o : all) {
      if (o.class_name() != g.class_name) continue;
      const Vec3d c_m(o.centroid_m().x(), o.centroid_m().y(), o.centroid_m().z());
      nearest_m = std::min(nearest_m, (c_m - T_map_b * g.centroid_m).norm());
    }
    EXPECT_LT(nearest_m, 0.05) << g.class_name << " (gt " << g.id << ") of room b";
    worst_m = std::max(worst_m, nearest_m);
    ++checked;
  }
  std::printf("  %d objects of room b in the shared map, the farthest %.1f mm from where B's "
              "placement puts it\n", checked, 1e3 * worst_m);
  EXPECT_GE(checked, 4);
  // B's and C's held keyframes entered the map in chunks (align.held_chunk_keyframes), the
  // mapping lock free between two.
  const loci::v1::AlignmentStats a = Stats(r.query.get()).alignment();
  const int64_t chunk = r.server->options().align.held_chunk_keyframes;
  ASSERT_GT(chunk, 0);
  // C may align first, ahead of its backlog, and B follow in a merge of its own.
  EXPECT_GE(a.merged_keyframes(), views_["b"].size());
  EXPECT_GT(a.last_merge_keyframes(), 0u);
  EXPECT_LE(a.last_merge_keyframes(), a.merged_keyframes());
  EXPECT_GE(a.last_merge_chunks(), (a.last_merge_keyframes() + chunk - 1) / chunk);
  EXPECT_LT(a.last_merge_longest_hold_ms(), a.last_merge_ms());
  // A restart gives back the same shared map: the merge is in the checkpoint.
  r.grpc.reset();
  r.server.reset();
  Running again = Start(dir_ + "/whole.db");
  ASSERT_TRUE(again.server);
  std::vector<loci::v1::Object> reloaded = Find(again.query.get(), true);
  ASSERT_EQ(reloaded.size(), all.size());
  for (size_t i = 0; i < all.size(); ++i) {
    EXPECT_EQ(reloaded[i].id(), all[i].id());
    EXPECT_NEAR(reloaded[i].centroid_m().x(), all[i].centroid_m().x(), 1e-6);
    EXPECT_NEAR(reloaded[i].centroid_m().y(), all[i].centroid_m().y(), 1e-6);
  }
}

// Keyframes held back in an island leave the shared map as it was, so they write no checkpoint
// of it (they used to count towards server.checkpoint_keyframes: the same checkpoint rewritten
// every few seconds while an unaligned robot streamed). The shared map's keyframes still do.
TEST_F(Islands, HeldKeyframesWriteNoCheckpoint) {
  ServerOptions options = testing::Options();
  options.align.loops.enabled = false;
  options.checkpoint_keyframes = 10;
  Running r = Start(dir_ + "/checkpoints.db", options);
  ASSERT_TRUE(r.server);
  Stream(r.mapping.get(), "A", Rebased(views_["a"], 0, false));
  r.server->Flush();
  const uint64_t after_a = Stats(r.query.get()).checkpoints_written();
  EXPECT_GE(after_a, 3u) << "45 keyframes at checkpoint_keyframes 10";

  Stream(r.mapping.get(), "B", Rebased(views_["b"], 0, true));
  r.server->Flush();
  const loci::v1::GetStatsResponse held = Stats(r.query.get());
  ASSERT_FALSE(SessionsByRobot(held).at("B").aligned()) << "room b is another place";
  EXPECT_EQ(held.checkpoints_written(), after_a) << "B's 45 held keyframes wrote checkpoints";

  std::vector<loci::v1::Keyframe> later = Rebased(views_["a"], 0, false);
  later.resize(12);
  for (auto& kf : later) kf.set_t_ns(kf.t_ns() + 100'000'000'000);
  Stream(r.mapping.get(), "A", later);
  r.server->Flush();
  EXPECT_EQ(Stats(r.query.get()).checkpoints_written(), after_a + 1)
      << "12 more keyframes of the shared map";
}

// A robot aligned as the server stopped: its held keyframes have ids below the checkpoint's
// (robot A streamed on meanwhile), and the checkpoint lacks them. The next start maps them.
TEST_F(Islands, HeldKeyframesTheCheckpointLacksAreMappedOnTheNextStart) {
  const std::string db = dir_ + "/missed.db";
  std::multiset<std::string> island_classes;
  SE3d T_island_odom;  // levels B's odometry frame, as a real alignment would
  {
    Running r = Start(db);
    ASSERT_TRUE(r.server);
    Stream(r.mapping.get(), "A", Rebased(views_["a"], 0, false));
    const std::string island = Stream(r.mapping.get(), "B", Rebased(views_["b"], 0, true));
    // A again, later: aligned in its own room, so the map's last keyframe id passes B's.
    std::vector<loci::v1::Keyframe> later = Rebased(views_["a"], 0, false);
    for (auto& kf : later) kf.set_t_ns(kf.t_ns() + 100'000'000'000);
    Stream(r.mapping.get(), "A", later);
    r.server->Flush();
    const auto sessions = SessionsByRobot(Stats(r.query.get()));
    ASSERT_FALSE(sessions.at("B").aligned());
    ASSERT_TRUE(sessions.at("A").aligned()) << "A's second session was not aligned";
    T_island_odom = PoseFromProto(sessions.at("B").t_island_odom());
    for (const auto& o : InIsland(Find(r.query.get(), true), island)) {
      island_classes.insert(o.class_name());
    }
    ASSERT_GE(island_classes.size(), 4u);
  }
  // As if the server had stopped just after storing B's placement (its island's levelled frame,
  // 50 m away): the checkpoint, written after A's last keyframe, holds none of B's keyframes.
  {
    auto store = SqliteStore::Open(db);
    ASSERT_TRUE(store.ok()) << store.status();
    auto stored = (*store)->ListSessions();
    ASSERT_TRUE(stored.ok());
    const auto b = std::find_if(stored->begin(), stored->end(),
                                [](const SessionRecord& s) { return s.robot_name == "B"; });
    ASSERT_NE(b, stored->end());
    const SE3d T_map_odom = MakeSE3(Vec3d(50, 0, 0), Quatd::Identity()) * T_island_odom;
    ASSERT_TRUE((*store)->SetSessionAlignment(b->row_id, T_map_odom).ok());
  }
  Running r = Start(db);
  ASSERT_TRUE(r.server);
  ASSERT_TRUE(r.server->readiness().Wait().ok());
  std::multiset<std::string> far_classes;
  for (const auto& o : Find(r.query.get(), true)) {
    EXPECT_EQ(o.island(), "") << "B is aligned: no island";
    const Vec3d c_m(o.centroid_m().x(), o.centroid_m().y(), o.centroid_m().z());
    if (c_m.norm() > 40) far_classes.insert(o.class_name());
  }
  EXPECT_EQ(far_classes, island_classes) << "room b's objects, 50 m away in the shared map";
}

}  // namespace
}  // namespace loci::server
