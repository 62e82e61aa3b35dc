// The map in PostgreSQL, end to end on loopback with a `loci synth` scene: the same map as with
// SQLite (live and after a restart); a writer killed with SIGKILL mid-stream, its standby taking
// over with every acknowledged keyframe kept; two sites mapped at once by two servers, each
// refusing the other site's robots. Loop closure is off: the maps are compared exactly.
#include <grpcpp/create_channel.h>
#include <gtest/gtest.h>
#include <libpq-fe.h>
#include <signal.h>
#include <sys/wait.h>

#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <set>
#include <thread>

#include "proto/json.h"
#include "server/postgres/postgres_store.h"
#include "server/runtime/proto_convert.h"
#include "server/runtime/map_server.h"
#include "server/runtime/server_detector.h"
#include "server/service/grpc_server.h"
#include "server/storage/sqlite_store.h"
#include "synth/scene.h"
#include "synth/sequence_writer.h"
#include "tests/server/grpc_stream.h"
#include "tests/server/keyframe_proto.h"
#include "tests/server/scene_stream.h"
#include "tests/support/server_process.h"
#include "tests/support/temp_postgres.h"

// Last: httplib pulls <resolv.h>, whose `_res` macro breaks Eigen headers included after it.
#include <httplib.h>

namespace loci::server {
namespace {

namespace fs = std::filesystem;
using loci::testing::ServerProcess;
using loci::testing::ServerProcessOptions;
using loci::testing::TempPostgres;

class PostgresServer : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new std::string(::testing::TempDir() + "/loci_postgres_server_" +
                           std::to_string(getpid()));
    fs::create_directories(*dir_);
    synth::SceneOptions scene;
    scene.seed = 1;
    scene.num_frames = 45;
    scene.fps_hz = 5.0;
    scene.num_objects = 8;
    ASSERT_TRUE(synth::WriteSequence(scene, *dir_ + "/scene").ok());
    auto kfs = testing::LoadSceneKeyframes(*dir_ + "/scene");
    ASSERT_TRUE(kfs.ok()) << kfs.status();
    keyframes_ = new std::vector<loci::v1::Keyframe>(std::move(*kfs));
    std::ofstream(*dir_ + "/server.yaml")
        << "map:\n  cloud:\n    max_depth_m: 6.0\n  octomap:\n    max_range_m: 6.0\n"
        << "align:\n  loops:\n    enabled: false\n"
        << "server:\n  lease_ttl_s: 3\n  lease_renew_s: 0.5\n";
  }
  static void TearDownTestSuite() {
    delete keyframes_;
    if (dir_ != nullptr) fs::remove_all(*dir_);
    delete dir_;
  }
  void SetUp() override {
    if (!TempPostgres::Available()) GTEST_SKIP() << "PostgreSQL 15 not installed";
    auto pg = TempPostgres::Start();
    ASSERT_TRUE(pg.ok()) << pg.status();
    pg_ = std::move(*pg);
  }

  static ServerOptions Options() {
    ServerOptions o;
    EXPECT_TRUE(o.FromYamlFile(*dir_ + "/server.yaml").ok());
    return o;
  }
  ServerProcessOptions Process(const std::string& site) const {
    return ServerProcessOptions{.db = *dir_ + "/unused.db",
                                .config = *dir_ + "/server.yaml",
                                .extra_args = {"--store", pg_->Uri(), "--site", site}};
  }
  static int Size() { return static_cast<int>(keyframes_->size()); }

  // Streams the whole scene through an in-process server on `store`; its confirmed objects and
  // cloud size after the queue drained.
  static std::vector<MapObject> Run(std::shared_ptr<MapStore> store, uint64_t* cloud_points) {
    return Run(std::move(store), cloud_points, Options(), nullptr, *keyframes_);
  }
  static std::vector<MapObject> Run(std::shared_ptr<MapStore> store, uint64_t* cloud_points,
                                    const ServerOptions& options,
                                    std::shared_ptr<KeyframeDetection> detection,
                                    const std::vector<loci::v1::Keyframe>& keyframes) {
    auto server = MapServer::Open(options, std::move(store), std::move(detection));
    EXPECT_TRUE(server.ok()) << server.status();
    if (!server.ok()) return {};
    auto grpc_server = GrpcServer::Start(server->get(), "127.0.0.1:0", 64);
    EXPECT_TRUE(grpc_server.ok());
    auto channel = grpc::CreateChannel(absl::StrCat("127.0.0.1:", (*grpc_server)->port()),
                                       grpc::InsecureChannelCredentials());
    auto mapping = loci::v1::Mapping::NewStub(channel);
    const std::string session = testing::OpenSessionOn(mapping.get(), "robot1", false);
    const int n = static_cast<int>(keyframes.size());
    const auto acks = testing::StreamAcked(mapping.get(), session, keyframes, 0, n);
    EXPECT_EQ(static_cast<int>(acks.size()), n);
    (*server)->Flush();
    auto query = loci::v1::Query::NewStub(channel);
    std::vector<MapObject> objects = testing::ConfirmedObjects(query.get());
    *cloud_points = Stats(query.get()).cloud_points();
    grpc_server->reset();
    return objects;
  }
  static loci::v1::GetStatsResponse Stats(loci::v1::Query::Stub* stub) {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
    loci::v1::GetStatsResponse stats;
    const grpc::Status s = stub->GetStats(&ctx, {}, &stats);
    EXPECT_TRUE(s.ok()) << s.error_message();
    return stats;
  }
  static void ExpectSameObjects(const std::vector<MapObject>& a, const std::vector<MapObject>& b) {
    ASSERT_EQ(a.size(), b.size());
    for (size_t i = 0; i < a.size(); ++i) {
      EXPECT_EQ(a[i].id, b[i].id);
      EXPECT_EQ(a[i].class_name, b[i].class_name);
      EXPECT_LT((a[i].centroid_m - b[i].centroid_m).norm(), 1e-9) << a[i].id;
      EXPECT_EQ(a[i].observation_count, b[i].observation_count);
    }
  }
  // The seqs stored in a site, in id order.
  std::vector<int64_t> StoredSeqs(const std::string& site) const {
    PostgresStoreOptions o;
    o.site = site;
    o.read_only = true;
    auto store = PostgresStore::Open(pg_->Uri(), o);
    EXPECT_TRUE(store.ok()) << store.status();
    std::vector<int64_t> seqs;
    if (!store.ok()) return seqs;
    KeyframeScan scan;
    scan.images = false;
    EXPECT_TRUE((*store)
                    ->ForEachKeyframe(0,
                                      [&](KeyframeRecord r) {
                                        seqs.push_back(r.seq);
                                        return absl::OkStatus();
                                      },
                                      scan)
                    .ok());
    return seqs;
  }

  std::unique_ptr<TempPostgres> pg_;
  static std::string* dir_;
  static std::vector<loci::v1::Keyframe>* keyframes_;
};

std::string* PostgresServer::dir_ = nullptr;
std::vector<loci::v1::Keyframe>* PostgresServer::keyframes_ = nullptr;

TEST_F(PostgresServer, SameMapAsSqliteLiveAndAfterARestart) {
  const std::string db = *dir_ + "/same.db";
  for (const char* s : {"", "-wal", "-shm"}) fs::remove(db + s);
  uint64_t sqlite_points = 0, pg_points = 0;
  std::vector<MapObject> from_sqlite, from_pg;
  {
    auto sqlite = SqliteStore::Open(db);
    ASSERT_TRUE(sqlite.ok()) << sqlite.status();
    from_sqlite = Run(std::shared_ptr<MapStore>(std::move(*sqlite)), &sqlite_points);
  }
  {
    auto pg = PostgresStore::Open(pg_->Uri());
    ASSERT_TRUE(pg.ok()) << pg.status();
    from_pg = Run(std::shared_ptr<MapStore>(std::move(*pg)), &pg_points);
  }
  ASSERT_GE(from_sqlite.size(), 5u);
  ExpectSameObjects(from_sqlite, from_pg);
  EXPECT_EQ(sqlite_points, pg_points);
  EXPECT_GT(pg_points, 0u);
  {  // Flush published the object table: every confirmed object is in it, whole.
    auto pg = PostgresStore::Open(pg_->Uri());
    ASSERT_TRUE(pg.ok()) << pg.status();
    auto published = (*pg)->ReadPublished();
    ASSERT_TRUE(published.ok()) << published.status();
    EXPECT_GT(published->version, 0);
    std::map<int64_t, ObjectRecord> by_id;
    for (const ObjectRecord& r : published->objects) by_id[r.id] = r;
    for (const MapObject& o : from_pg) {
      ASSERT_TRUE(by_id.count(o.id)) << "object " << o.id << " not in the object table";
      EXPECT_TRUE(by_id[o.id].confirmed);
      EXPECT_EQ(by_id[o.id].class_name, o.class_name);
      EXPECT_LT((by_id[o.id].centroid_m - o.centroid_m).norm(), 1e-9);
      EXPECT_LT((by_id[o.id].min_m - o.aabb_min_m).norm(), 1e-9);
      loci::v1::Object wire;
      ASSERT_TRUE(wire.ParseFromString(by_id[o.id].wire));
      EXPECT_EQ(wire.id(), o.id);
      EXPECT_EQ(wire.class_name(), o.class_name);
    }
  }

  // A restart loads the map the shutdown checkpointed, from each store.
  for (int which = 0; which < 2; ++which) {
    std::shared_ptr<MapStore> store;
    if (which == 0) {
      store = std::move(*SqliteStore::Open(db));
    } else {
      store = std::move(*PostgresStore::Open(pg_->Uri()));
    }
    auto server = MapServer::Open(Options(), store);
    ASSERT_TRUE(server.ok()) << server.status();
    EXPECT_EQ((*server)->load_report().checkpoint_keyframe_id, Size());
    std::vector<MapObject> reloaded;
    for (const MapObject& o : (*server)->mapper().Snapshot(true)) {
      if (o.confirmed) reloaded.push_back(o);
    }
    ExpectSameObjects(from_sqlite, reloaded);
  }
}

// The repository's real sample (60 fr1_rpy frames at their ground-truth poses), detected on the
// server by the shipped YOLOX-Nano: the same objects and cloud from SQLite and PostgreSQL.
TEST_F(PostgresServer, SameMapAsSqliteOnTheShippedRealSample) {
  const std::string src = LOCI_SOURCE_DIR;
  auto kfs = testing::LoadSceneKeyframes(src + "/tests/data/tum_fr1_rpy_sample");
  ASSERT_TRUE(kfs.ok()) << kfs.status();
  const std::string config = *dir_ + "/sample.yaml";
  std::ofstream(config) << "align:\n  loops:\n    enabled: false\n"
                        << "detector:\n  enabled: true\n  mode: all\n  threads: 1\n"
                        << "  type: yolox\n  model: " << src << "/models/yolox_nano/yolox_nano.onnx\n"
                        << "  class_names: " << src << "/models/yolox_nano/coco80.names\n"
                        << "  input_size_px: 416\n  score_threshold: 0.3\n"
                        << "  classes_file: " << src << "/config/classes.yaml\n";
  ServerOptions options;
  ASSERT_TRUE(options.FromYamlFile(config).ok());
  auto detection = MakeServerDetection(options, config);
  if (!detection.ok() && detection.status().code() == absl::StatusCode::kFailedPrecondition) {
    GTEST_SKIP() << detection.status();  // a build without the detection module
  }
  ASSERT_TRUE(detection.ok()) << detection.status();
  const std::string db = *dir_ + "/sample.db";
  for (const char* s : {"", "-wal", "-shm"}) fs::remove(db + s);
  uint64_t sqlite_points = 0, pg_points = 0;
  auto sqlite = SqliteStore::Open(db);
  ASSERT_TRUE(sqlite.ok()) << sqlite.status();
  const std::vector<MapObject> from_sqlite = Run(std::shared_ptr<MapStore>(std::move(*sqlite)),
                                                 &sqlite_points, options, *detection, *kfs);
  auto pg = PostgresStore::Open(pg_->Uri());
  ASSERT_TRUE(pg.ok()) << pg.status();
  const std::vector<MapObject> from_pg = Run(std::shared_ptr<MapStore>(std::move(*pg)),
                                             &pg_points, options, *detection, *kfs);
  ASSERT_GE(from_sqlite.size(), 1u) << "the sample gave no confirmed object to compare";
  ExpectSameObjects(from_sqlite, from_pg);
  EXPECT_EQ(sqlite_points, pg_points);
  EXPECT_GT(pg_points, 0u);
}

// The writer dies with SIGKILL while keyframes stream in; the standby, waiting on the site's
// lease, takes over once the lease lapses; the robot resumes on it; every keyframe the dead
// writer acknowledged is there, and the map holds each keyframe once.
TEST_F(PostgresServer, StandbyTakesOverAfterSigkillWithNothingAcknowledgedLost) {
  const int n = Size();
  std::set<int64_t> acked;
  auto writer = std::make_unique<ServerProcess>(Process("lab"));
  ASSERT_GT(writer->port(), 0);
  // The standby's constructor returns once it listens: after it took the lease over.
  std::unique_ptr<ServerProcess> standby;
  std::chrono::steady_clock::time_point killed_at, ready_at;
  std::thread standby_start([&] {
    standby = std::make_unique<ServerProcess>(Process("lab"));
    ready_at = std::chrono::steady_clock::now();
  });
  {
    auto channel = grpc::CreateChannel(writer->address(), grpc::InsecureChannelCredentials());
    auto mapping = loci::v1::Mapping::NewStub(channel);
    const std::string session = testing::OpenSessionOn(mapping.get(), "robot1", false, nullptr,
                                                       "lab");
    for (const auto& a : testing::StreamAcked(mapping.get(), session, *keyframes_, 0, n / 3)) {
      if (a.status().code() == 0) acked.insert(a.seq());
    }
    testing::StreamAndKill(mapping.get(), session, *keyframes_, n / 3, n * 2 / 3, n / 2,
                           writer.get(), &acked);
    killed_at = std::chrono::steady_clock::now();
  }
  standby_start.join();
  ASSERT_GT(standby->port(), 0);
  ASSERT_GE(acked.size(), static_cast<size_t>(n / 3));
  const double takeover_s = std::chrono::duration<double>(ready_at - killed_at).count();
  std::cout << "takeover: the standby listened " << takeover_s << " s after the SIGKILL\n";
  RecordProperty("takeover_s", std::to_string(takeover_s));

  auto channel = grpc::CreateChannel(standby->address(), grpc::InsecureChannelCredentials());
  auto mapping = loci::v1::Mapping::NewStub(channel);
  int64_t last = -2;
  const std::string session =
      testing::OpenSessionOn(mapping.get(), "robot1", /*resume=*/true, &last, "lab");
  EXPECT_EQ(session.substr(0, 9), "robot1-1-");
  EXPECT_GE(last, *acked.rbegin());  // everything acknowledged survived
  const auto acks =
      testing::StreamAcked(mapping.get(), session, *keyframes_, static_cast<int>(last) + 1, n);
  EXPECT_EQ(static_cast<int>(acks.size()), n - static_cast<int>(last) - 1);
  for (const auto& a : acks) EXPECT_EQ(a.status().code(), 0) << a.status().message();
  auto query = loci::v1::Query::NewStub(channel);
  EXPECT_EQ(Stats(query.get()).keyframes(), static_cast<uint64_t>(n));
  const int status = standby->Stop(SIGTERM);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "wait status " << status;

  std::vector<int64_t> seqs = StoredSeqs("lab");
  ASSERT_EQ(static_cast<int>(seqs.size()), n);
  std::sort(seqs.begin(), seqs.end());
  for (int i = 0; i < n; ++i) EXPECT_EQ(seqs[i], i);
}

// A writer whose lease another server took (here: the row's epoch bumped by hand, as a takeover
// after a long pause would) stops with exit status 3 and writes nothing more.
TEST_F(PostgresServer, AWriterThatLostItsLeaseStops) {
  ServerProcess writer(Process("lab"));
  ASSERT_GT(writer.port(), 0);
  PGconn* c = PQconnectdb(pg_->Uri().c_str());
  PGresult* r = PQexec(c, "UPDATE loci_site_leases SET epoch = epoch + 1 WHERE site = 'lab'");
  EXPECT_EQ(PQresultStatus(r), PGRES_COMMAND_OK) << PQresultErrorMessage(r);
  PQclear(r);
  PQfinish(c);
  const int status = writer.Stop(0);  // waits: the server ends by itself
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 3) << "wait status " << status;
}

TEST_F(PostgresServer, TwoSitesMappedAtOnceByTwoServers) {
  ServerProcess a(Process("site-a"));
  ServerProcess b(Process("site-b"));
  ASSERT_GT(a.port(), 0);
  ASSERT_GT(b.port(), 0);
  const int n = Size();
  auto stream_to = [&](const ServerProcess& server, const std::string& site, int begin,
                       int end) {
    auto channel = grpc::CreateChannel(server.address(), grpc::InsecureChannelCredentials());
    auto mapping = loci::v1::Mapping::NewStub(channel);
    const std::string session =
        testing::OpenSessionOn(mapping.get(), "robot-" + site, false, nullptr, site);
    const auto acks = testing::StreamAcked(mapping.get(), session, *keyframes_, begin, end);
    EXPECT_EQ(static_cast<int>(acks.size()), end - begin);
  };
  std::thread to_a([&] { stream_to(a, "site-a", 0, n / 2); });
  std::thread to_b([&] { stream_to(b, "site-b", n / 2, n); });
  to_a.join();
  to_b.join();
  {  // A robot naming the other site is refused, saying which site this server maps.
    auto channel = grpc::CreateChannel(a.address(), grpc::InsecureChannelCredentials());
    auto mapping = loci::v1::Mapping::NewStub(channel);
    grpc::ClientContext ctx;
    loci::v1::OpenSessionRequest req =
        testing::OpenRequest("robot-x", PinholeCamera::TumFr1(), false);
    req.set_site("site-b");
    loci::v1::OpenSessionResponse resp;
    const grpc::Status s = mapping->OpenSession(&ctx, req, &resp);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
    EXPECT_NE(s.error_message().find("site-a"), std::string::npos) << s.error_message();
  }
  EXPECT_EQ(a.Stop(SIGTERM), 0);
  EXPECT_EQ(b.Stop(SIGTERM), 0);
  EXPECT_EQ(static_cast<int>(StoredSeqs("site-a").size()), n / 2);
  EXPECT_EQ(static_cast<int>(StoredSeqs("site-b").size()), n - n / 2);
}

// Every object of a FindObjects answer: id, class and centroid, by id.
std::map<int64_t, std::pair<std::string, Vec3d>> AllObjects(loci::v1::Query::Stub* stub) {
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
  loci::v1::FindObjectsRequest req;
  loci::v1::FindObjectsResponse resp;
  const grpc::Status s = stub->FindObjects(&ctx, req, &resp);
  EXPECT_TRUE(s.ok()) << s.error_message();
  std::map<int64_t, std::pair<std::string, Vec3d>> out;
  for (const auto& o : resp.objects()) {
    out[o.id()] = {o.class_name(), Vec3d(o.centroid_m().x(), o.centroid_m().y(),
                                         o.centroid_m().z())};
  }
  return out;
}

bool SameObjects(const std::map<int64_t, std::pair<std::string, Vec3d>>& a,
                 const std::map<int64_t, std::pair<std::string, Vec3d>>& b) {
  if (a.size() != b.size()) return false;
  for (const auto& [id, o] : a) {
    const auto it = b.find(id);
    if (it == b.end() || it->second.first != o.first ||
        (it->second.second - o.second).norm() > 1e-9) {
      return false;
    }
  }
  return true;
}

// A WatchObjects stream read on its own thread: every event, and a wait for the next ones.
class EventLog {
 public:
  explicit EventLog(loci::v1::Query::Stub* stub) : reader_(stub->WatchObjects(&ctx_, {})) {
    reader_->WaitForInitialMetadata();  // sent once the watch is registered
    thread_ = std::thread([this] {
      loci::v1::ObjectEvent e;
      while (reader_->Read(&e)) {
        std::lock_guard<std::mutex> lock(mu_);
        events_.push_back(e);
        cv_.notify_all();
      }
    });
  }
  ~EventLog() {
    ctx_.TryCancel();
    thread_.join();
  }
  // Once more than `seen` events arrived, or after `timeout`: how many there are.
  size_t WaitBeyond(size_t seen, std::chrono::seconds timeout) {
    std::unique_lock<std::mutex> lock(mu_);
    cv_.wait_for(lock, timeout, [&] { return events_.size() > seen; });
    return events_.size();
  }
  std::vector<loci::v1::ObjectEvent> events() {
    std::lock_guard<std::mutex> lock(mu_);
    return events_;
  }

 private:
  grpc::ClientContext ctx_;
  std::unique_ptr<grpc::ClientReader<loci::v1::ObjectEvent>> reader_;
  std::mutex mu_;
  std::condition_variable cv_;
  std::vector<loci::v1::ObjectEvent> events_;  // guarded by mu_
  std::thread thread_;
};

// The map the events build from an empty one: the objects of CREATED, UPDATED and MOVED, less
// the REMOVED.
std::map<int64_t, std::pair<std::string, Vec3d>> Replayed(
    const std::vector<loci::v1::ObjectEvent>& events) {
  std::map<int64_t, std::pair<std::string, Vec3d>> out;
  for (const loci::v1::ObjectEvent& e : events) {
    const MapObject o = FromProto(e.object());
    if (e.kind() == loci::v1::ObjectEvent::REMOVED) {
      out.erase(o.id);
    } else {
      out[o.id] = {o.class_name, o.centroid_m};
    }
  }
  return out;
}

// A read-only query server of a site answers from the map its writer publishes: the same
// objects and answers as the writer once the writer's map has settled, over gRPC and HTTP;
// WatchObjects streams each publication's changes, which rebuild the same map, each object
// created once; the writer's address for robots and for what only the writer serves; the last
// map still after the writer stopped.
TEST_F(PostgresServer, ReadOnlyServerAnswersFromTheWritersPublishedMap) {
  ServerProcess writer(Process("lab"));
  ASSERT_GT(writer.port(), 0);
  ServerProcessOptions replica_options = Process("lab");
  replica_options.extra_args.insert(replica_options.extra_args.end(),
                                    {"--read-only", "--http", "127.0.0.1:0"});
  ServerProcess replica(replica_options);  // returns once it is SERVING
  ASSERT_GT(replica.port(), 0);
  ASSERT_GT(replica.http_port(), 0);
  ASSERT_TRUE(replica.serving().ok()) << replica.serving();
  auto writer_channel = grpc::CreateChannel(writer.address(), grpc::InsecureChannelCredentials());
  auto replica_channel =
      grpc::CreateChannel(replica.address(), grpc::InsecureChannelCredentials());
  auto writer_query = loci::v1::Query::NewStub(writer_channel);
  auto replica_query = loci::v1::Query::NewStub(replica_channel);
  EXPECT_TRUE(AllObjects(replica_query.get()).empty());
  EventLog watch(replica_query.get());
  {  // Robots are sent to the writer.
    auto mapping = loci::v1::Mapping::NewStub(replica_channel);
    grpc::ClientContext ctx;
    loci::v1::OpenSessionResponse resp;
    const grpc::Status s = mapping->OpenSession(
        &ctx, testing::OpenRequest("robot1", PinholeCamera::TumFr1(), false), &resp);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
    EXPECT_NE(s.error_message().find(writer.address()), std::string::npos) << s.error_message();
  }
  {
    auto mapping = loci::v1::Mapping::NewStub(writer_channel);
    const std::string session =
        testing::OpenSessionOn(mapping.get(), "robot1", false, nullptr, "lab");
    EXPECT_EQ(static_cast<int>(
                  testing::StreamAcked(mapping.get(), session, *keyframes_, 0, Size()).size()),
              Size());
  }
  // The writer publishes about once a second while its map changes; each publication the
  // read-only server loads is an event batch, the signal to compare again (the writer's map
  // settles once its queue drained; a last publication without object changes sends nothing,
  // hence the 2 s bound on a wait).
  std::map<int64_t, std::pair<std::string, Vec3d>> on_writer, on_replica;
  size_t seen = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (std::chrono::steady_clock::now() < deadline) {
    on_writer = AllObjects(writer_query.get());
    on_replica = AllObjects(replica_query.get());
    if (!on_writer.empty() && Stats(writer_query.get()).mapped_keyframes() ==
                                  static_cast<uint64_t>(Size()) &&
        SameObjects(on_writer, on_replica)) {
      break;
    }
    seen = watch.WaitBeyond(seen, std::chrono::seconds(2));
  }
  ASSERT_GE(on_writer.size(), 5u);
  ASSERT_TRUE(SameObjects(on_writer, on_replica))
      << on_writer.size() << " objects on the writer, " << on_replica.size() << " read-only";
  // A query may see a publication just before its events are queued: wait for them.
  while (!SameObjects(Replayed(watch.events()), on_replica) &&
         watch.WaitBeyond(seen, std::chrono::seconds(5)) > seen) {
    seen = watch.events().size();
  }
  const std::vector<loci::v1::ObjectEvent> events = watch.events();
  EXPECT_TRUE(SameObjects(Replayed(events), on_replica)) << events.size() << " events";
  std::map<int64_t, int> created;
  for (const loci::v1::ObjectEvent& e : events) {
    if (e.kind() == loci::v1::ObjectEvent::CREATED) ++created[e.object().id()];
  }
  for (const auto& [id, o] : on_replica) EXPECT_EQ(created[id], 1) << "object " << id;

  const std::string cls = on_writer.begin()->second.first;
  auto ask = [&](loci::v1::Query::Stub* stub) {
    grpc::ClientContext ctx;
    loci::v1::AskRequest req;
    req.set_text("where is the " + cls + "?");
    loci::v1::AskResponse resp;
    const grpc::Status s = stub->Ask(&ctx, req, &resp);
    EXPECT_TRUE(s.ok()) << s.error_message();
    std::vector<int64_t> ids;
    for (const auto& o : resp.objects()) ids.push_back(o.id());
    return ids;
  };
  const std::vector<int64_t> asked = ask(writer_query.get());
  EXPECT_FALSE(asked.empty());
  EXPECT_EQ(ask(replica_query.get()), asked);
  const loci::v1::GetStatsResponse stats = Stats(replica_query.get());
  EXPECT_EQ(stats.keyframes(), static_cast<uint64_t>(Size()));
  EXPECT_EQ(stats.objects(), on_writer.size());
  {  // The cloud stays with the writer.
    grpc::ClientContext ctx;
    loci::v1::GetCloudResponse cloud;
    const grpc::Status s = replica_query->GetCloud(&ctx, {}, &cloud);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
    EXPECT_NE(s.error_message().find(writer.address()), std::string::npos) << s.error_message();
  }
  {  // HTTP: the same objects and answers; the cloud at the writer.
    httplib::Client http("127.0.0.1", replica.http_port());
    auto objects = http.Get("/api/objects");
    ASSERT_TRUE(objects) << httplib::to_string(objects.error());
    EXPECT_EQ(objects->status, 200) << objects->body;
    loci::v1::FindObjectsResponse found;
    ASSERT_TRUE(JsonToProto(objects->body, &found).ok()) << objects->body;
    std::map<int64_t, std::pair<std::string, Vec3d>> over_http;
    for (const auto& o : found.objects()) {
      over_http[o.id()] = {o.class_name(), FromProto(o).centroid_m};
    }
    EXPECT_TRUE(SameObjects(over_http, on_replica));
    auto answer = http.Get(("/api/ask?q=where+is+the+" + cls).c_str());
    ASSERT_TRUE(answer);
    loci::v1::AskResponse asked_http;
    ASSERT_TRUE(JsonToProto(answer->body, &asked_http).ok()) << answer->body;
    std::vector<int64_t> ids;
    for (const auto& o : asked_http.objects()) ids.push_back(o.id());
    EXPECT_EQ(ids, asked);
    auto cloud = http.Get("/api/cloud");
    ASSERT_TRUE(cloud);
    EXPECT_NE(cloud->status, 200);
    EXPECT_NE(cloud->body.find("FAILED_PRECONDITION"), std::string::npos) << cloud->body;
    EXPECT_NE(cloud->body.find(writer.address()), std::string::npos) << cloud->body;
  }
  EXPECT_EQ(writer.Stop(SIGTERM), 0);
  EXPECT_TRUE(SameObjects(AllObjects(replica_query.get()), on_writer));
  EXPECT_EQ(replica.Stop(SIGTERM), 0);
}

}  // namespace
}  // namespace loci::server
