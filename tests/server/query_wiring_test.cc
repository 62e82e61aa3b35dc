// The query engine wired into a real server on loopback: a `loci synth` scene streamed over gRPC
// (ground-truth poses, detections, accelerometer), then every "on" relation of objects.json among
// the mapped objects asked over gRPC and HTTP ("where is the X on the Y", "what is on #id"),
// counts, negative questions, unknown words, garbage questions, HTTP == gRPC JSON; and the
// plane-based up estimate on the map's cloud.
#include <grpcpp/create_channel.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "common/objects_json.h"
#include "loci/v1/mapping.grpc.pb.h"
#include "loci/v1/query.grpc.pb.h"
#include "proto/json.h"
#include "server/http/http_api.h"
#include "server/map/object_eval.h"
#include "server/service/grpc_server.h"
#include "server/runtime/map_server.h"
#include "server/service/query_adapter.h"
#include "synth/sequence_writer.h"
#include "tests/server/keyframe_proto.h"
#include "tests/server/scene_stream.h"

// Last: httplib pulls <resolv.h>, whose `_res` macro breaks Eigen headers included after it.
#include <httplib.h>

namespace loci::server {
namespace {

namespace fs = std::filesystem;

// A running server: MapServer + gRPC (with the QueryAdapter) + HTTP, all on loopback.
struct LiveServer {
  std::unique_ptr<MapServer> map;
  std::unique_ptr<GrpcServer> grpc;
  std::unique_ptr<HttpApi> http;
  std::shared_ptr<QueryAdapter> adapter;
  std::unique_ptr<loci::v1::Query::Stub> query;
  std::unique_ptr<loci::v1::Mapping::Stub> mapping;
  std::unique_ptr<httplib::Client> client;

  void Start(const ServerOptions& options, int64_t now_ns) {
    auto m = MapServer::Open(options);
    ASSERT_TRUE(m.ok()) << m.status();
    map = std::move(*m);
    QueryAdapterOptions qo;
    qo.now_ns = [now_ns] { return now_ns; };  // fixed: "seen N s ago" equal over both transports
    adapter = std::make_shared<QueryAdapter>(qo);
    auto g = GrpcServer::Start(map.get(), "127.0.0.1:0", 64, adapter);
    ASSERT_TRUE(g.ok()) << g.status();
    grpc = std::move(*g);
    auto h = HttpApi::Start(grpc->query_service(), "127.0.0.1:0");
    ASSERT_TRUE(h.ok()) << h.status();
    http = std::move(*h);
    auto channel = grpc::CreateChannel(absl::StrCat("127.0.0.1:", grpc->port()),
                                       grpc::InsecureChannelCredentials());
    query = loci::v1::Query::NewStub(channel);
    mapping = loci::v1::Mapping::NewStub(channel);
    client = std::make_unique<httplib::Client>("127.0.0.1", http->port());
  }

  // Asks over gRPC: the call's status and the response.
  std::pair<grpc::Status, loci::v1::AskResponse> AskGrpc(const std::string& text) {
    grpc::ClientContext ctx;
    loci::v1::AskRequest req;
    req.set_text(text);
    loci::v1::AskResponse resp;
    const grpc::Status s = query->Ask(&ctx, req, &resp);
    return {s, resp};
  }

  // GET path (already encoded); returns {HTTP status, body}.
  std::pair<int, std::string> Get(const std::string& path) {
    auto res = client->Get(path.c_str());
    if (!res) return {-1, ""};
    return {res->status, res->body};
  }

  // Asks over gRPC and HTTP; expects an answer, the same JSON from both.
  loci::v1::AskResponse Ask(const std::string& text) {
    const auto [s, resp] = AskGrpc(text);
    EXPECT_TRUE(s.ok()) << text << ": " << s.error_message();
    const auto [status, body] = Get("/api/ask?q=" + httplib::detail::encode_query_param(text));
    EXPECT_EQ(status, 200) << text;
    EXPECT_EQ(body, ProtoToJson(resp)) << text;
    return resp;
  }

  // Asks a question the server must refuse: a failed gRPC call, and over HTTP 400 with the same
  // code and message as {"error": {...}}. Returns the gRPC status.
  grpc::Status AskRefused(const std::string& text) {
    const grpc::Status s = AskGrpc(text).first;
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << text;
    const auto [status, body] = Get("/api/ask?q=" + httplib::detail::encode_query_param(text));
    EXPECT_EQ(status, 400) << text;
    const nlohmann::json j = nlohmann::json::parse(body, nullptr, false);
    EXPECT_EQ(j["error"]["code"], "INVALID_ARGUMENT") << body;
    EXPECT_EQ(j["error"]["message"], s.error_message()) << body;
    return s;
  }
};

std::set<int64_t> Ids(const loci::v1::AskResponse& r) {
  std::set<int64_t> ids;
  for (const auto& o : r.objects()) ids.insert(o.id());
  return ids;
}

std::string Plural(const std::string& c) {
  if (c == "mouse") return "mice";
  if (c == "person") return "people";
  if (c.back() == 's' || c.back() == 'h') return c + "es";
  return c + "s";
}

// Garbage never crashes the server and is answered with a status.
void AskGarbage(LiveServer& s) {
  const std::string big(100 * 1024, 'a');
  std::string binary;
  for (int i = 0; i < 512; ++i) binary.push_back(static_cast<char>((i * 37) & 0xFF));
  for (const std::string& q : {std::string(), big, binary, std::string("where is the \xff\xfe")}) {
    grpc::ClientContext ctx;
    loci::v1::AskRequest req;
    req.set_text(q);
    loci::v1::AskResponse resp;
    (void)s.query->Ask(&ctx, req, &resp);  // invalid UTF-8 may fail in transport: either is fine
    const auto [status, body] = s.Get("/api/ask?q=" + httplib::detail::encode_query_param(q));
    EXPECT_TRUE(status == 200 || status == 400 || status == 414) << status;
  }
  const grpc::Status too_long = s.AskGrpc(big).first;
  EXPECT_EQ(too_long.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(too_long.error_message().find("bytes long"), std::string::npos);
  const grpc::Status after = s.AskGrpc("list all objects").first;  // still serving
  EXPECT_TRUE(after.ok()) << after.error_message();
}

TEST(QueryWiring, EmptyServerHttpErrorsAndGarbage) {
  const std::string dir =
      ::testing::TempDir() + "/loci_query_wiring_empty_" + std::to_string(getpid());
  fs::create_directories(dir);
  ServerOptions o;
  ASSERT_TRUE(o.LoadClasses().ok());
  o.db_path = dir + "/empty.db";
  LiveServer s;
  s.Start(o, 0);
  ASSERT_TRUE(s.grpc);
  EXPECT_EQ(s.Ask("how many chairs are there").count(), 0);
  EXPECT_EQ(s.Get("/api/ask").first, 400);
  EXPECT_NE(s.Get("/api/ask").second.find("\"INVALID_ARGUMENT\""), std::string::npos);
  const auto [missing_status, missing_body] = s.Get("/api/objects/12345");
  EXPECT_EQ(missing_status, 404);
  EXPECT_EQ(missing_body, R"({"error":{"code":"NOT_FOUND","message":"no object 12345"}})");
  EXPECT_EQ(s.Get("/api/objects/abc").first, 400);
  EXPECT_EQ(s.Get("/api/objects?min_confidence=2").first, 400);
  EXPECT_EQ(s.Get("/api/nothing").first, 404);
  const auto [stats_status, stats_body] = s.Get("/api/stats");
  EXPECT_EQ(stats_status, 200);
  EXPECT_NE(stats_body.find("\"keyframes\":\"0\""), std::string::npos) << stats_body;
  AskGarbage(s);
  s.http.reset();
  s.grpc.reset();
  s.map.reset();
  fs::remove_all(dir);
}

TEST(QueryWiring, SynthSceneRelationsCountsAndTransportsAgree) {
  const std::string dir = ::testing::TempDir() + "/loci_query_wiring_" + std::to_string(getpid());
  fs::create_directories(dir);
  synth::SceneOptions so;
  so.seed = 3;
  so.num_frames = 30;
  so.fps_hz = 4.0;  // 7.5 s of the camera path from 30 frames
  so.num_objects = 8;
  ASSERT_TRUE(synth::WriteSequence(so, dir + "/scene").ok());
  auto keyframes = testing::LoadSceneKeyframes(dir + "/scene");
  ASSERT_TRUE(keyframes.ok()) << keyframes.status();
  auto gt = ReadObjectsJson(dir + "/scene/objects.json");
  ASSERT_TRUE(gt.ok());
  std::ofstream(dir + "/server.yaml")
      << "map:\n  cloud:\n    max_depth_m: 6.0\n  octomap:\n    max_range_m: 6.0\n";
  ServerOptions options;
  ASSERT_TRUE(options.FromYamlFile(dir + "/server.yaml").ok());
  options.db_path = dir + "/map.db";

  LiveServer s;
  s.Start(options, keyframes->back().t_ns() + 5'000'000'000);
  ASSERT_TRUE(s.grpc);
  {
    grpc::ClientContext ctx;
    loci::v1::OpenSessionResponse open;
    ASSERT_TRUE(s.mapping
                    ->OpenSession(
                        &ctx, testing::OpenRequest("robot1", PinholeCamera::TumFr1(), false), &open)
                    .ok());
    grpc::ClientContext sctx;
    auto stream = s.mapping->StreamKeyframes(&sctx);
    for (loci::v1::Keyframe kf : *keyframes) {
      kf.set_session_id(open.session_id());
      ASSERT_TRUE(stream->Write(kf));
      loci::v1::KeyframeAck ack;
      ASSERT_TRUE(stream->Read(&ack));
      ASSERT_EQ(ack.status().code(), 0) << ack.status().message();
    }
    stream->WritesDone();
    ASSERT_TRUE(stream->Finish().ok());
  }
  s.map->Flush();

  // Ground truth objects that made it into the map: matched by the object evaluation.
  // Matched in the synth world (the map frame is it levelled and anchored at the first
  // keyframe); relations are asked of the map itself.
  const SE3d T_world_map = s.map->mapper().MapFromBaseFrame().inverse();
  std::vector<MapObject> mapped;
  for (const MapObject& o : s.map->mapper().Snapshot(true)) {
    mapped.push_back(Transformed(o, T_world_map));
  }
  ObjectEvalOptions eo;
  for (const auto& c : options.map.mapped_classes) {
    if (!options.map.IsDynamic(c)) eo.classes.push_back(c);
  }
  const ObjectEvalResult eval = EvaluateObjects(mapped, *gt, eo);
  std::map<int64_t, int64_t> map_id_of;  // gt id -> map id
  for (const ObjectMatch& m : eval.matches) map_id_of[m.gt_id] = m.object_id;
  std::map<int64_t, const GroundTruthObject*> gt_by_id;
  for (const auto& o : gt->objects) gt_by_id[o.id] = &o;
  ASSERT_GE(map_id_of.size(), 5u) << "too few objects mapped to test relations";

  // The keyframes carry gravity, refined by the floor and table-top planes.
  EXPECT_EQ(s.Ask("list all objects").count(), static_cast<int64_t>(mapped.size()));
  EXPECT_EQ(s.adapter->up_source(), "map frame (gravity+planes)");

  // Every "on" relation among mapped objects.
  std::map<int64_t, std::set<int64_t>> on_gt;  // support map id -> map ids on it
  int relations_checked = 0;
  for (const auto& [gt_id, map_id] : map_id_of) {
    const GroundTruthObject& o = *gt_by_id[gt_id];
    if (o.on_id == 0 || !map_id_of.count(o.on_id)) continue;
    const int64_t support = map_id_of[o.on_id];
    on_gt[support].insert(map_id);
    const std::string q =
        absl::StrCat("where is the ", o.class_name, " on the ", gt_by_id[o.on_id]->class_name);
    const loci::v1::AskResponse r = s.Ask(q);
    EXPECT_TRUE(Ids(r).count(map_id)) << q << " -> " << r.answer();
    bool relation_found = false;
    for (const auto& rel : r.relations()) {
      relation_found |=
          rel.name() == "on" && rel.subject_id() == map_id && rel.anchor_id() == support;
    }
    EXPECT_TRUE(relation_found) << q << " -> " << r.answer();
    ++relations_checked;
  }
  EXPECT_GE(relations_checked, 4);
  for (const auto& [support, on] : on_gt) {
    const std::string q = absl::StrCat("what is on #", support);
    const loci::v1::AskResponse r = s.Ask(q);
    EXPECT_EQ(Ids(r), on) << q << " -> " << r.answer();
    EXPECT_EQ(r.count(), static_cast<int64_t>(on.size())) << q;
  }

  // Counts per class = mapped ground truth of that class = the server's confirmed objects.
  std::map<std::string, int64_t> gt_count;
  for (const auto& [gt_id, map_id] : map_id_of) ++gt_count[gt_by_id[gt_id]->class_name];
  for (const auto& [cls, n] : gt_count) {
    const std::string q = absl::StrCat("how many ", Plural(cls), " are there");
    const loci::v1::AskResponse r = s.Ask(q);
    EXPECT_EQ(r.count(), n) << q << " -> " << r.answer();
  }

  // Negative questions say no.
  const std::string table = gt_by_id[1]->class_name;
  const loci::v1::AskResponse elephant = s.Ask("is there an elephant on the " + table);
  EXPECT_EQ(elephant.count(), 0);
  EXPECT_TRUE(elephant.objects().empty());
  EXPECT_EQ(s.Ask("how many elephants are there").count(), 0);
  int negatives = 0;
  for (const auto& [gt_id, map_id] : map_id_of) {
    const GroundTruthObject& o = *gt_by_id[gt_id];
    if (o.on_id == 1 || gt_id == 1) continue;  // not on the table
    const loci::v1::AskResponse r = s.Ask(absl::StrCat("is #", map_id, " on #", map_id_of[1]));
    EXPECT_EQ(r.answer().rfind("No", 0), 0u) << o.class_name << ": " << r.answer();
    ++negatives;
  }
  EXPECT_GE(negatives, 1);

  // Unknown words: INVALID_ARGUMENT listing the known classes, 400 over HTTP.
  const grpc::Status unknown = s.AskRefused("where is the flibbertigibbet");
  EXPECT_NE(unknown.error_message().find("dining table"), std::string::npos);
  EXPECT_NE(unknown.error_message().find("cup"), std::string::npos);

  // HTTP objects / object / stats carry the gRPC messages' JSON.
  {
    grpc::ClientContext ctx;
    loci::v1::FindObjectsRequest req;
    req.add_classes(table);
    loci::v1::FindObjectsResponse resp;
    ASSERT_TRUE(s.query->FindObjects(&ctx, req, &resp).ok());
    EXPECT_EQ(resp.objects_size(), 1);
    EXPECT_EQ(s.Get("/api/objects?class=" + httplib::detail::encode_query_param(table)).second,
              ProtoToJson(resp));
    grpc::ClientContext octx;
    loci::v1::GetObjectRequest oreq;
    oreq.set_id(map_id_of[1]);
    loci::v1::GetObjectResponse oresp;
    ASSERT_TRUE(s.query->GetObject(&octx, oreq, &oresp).ok());
    EXPECT_EQ(s.Get(absl::StrCat("/api/objects/", map_id_of[1])).second, ProtoToJson(oresp));
  }
  AskGarbage(s);

  // Plane-based up on the real map cloud (floor, table top, shelf): within 3 deg of gravity
  // (+z of the synth world = map frame), also from a prior tilted by 25 deg.
  const auto cloud = MapperSource(s.map->mapper()).CloudPoints(0.08);
  QueryAdapterOptions ao;
  const Vec3d tilted = Eigen::AngleAxisd(25.0 * M_PI / 180.0, Vec3d::UnitX()) * Vec3d::UnitZ();
  for (const Vec3d& prior : {Vec3d(Vec3d::UnitZ()), tilted}) {
    const std::optional<Vec3d> up = EstimateUpFromPlanes(cloud, prior, ao.up_planes);
    ASSERT_TRUE(up.has_value());
    EXPECT_GT(up->dot(Vec3d::UnitZ()), std::cos(3.0 * M_PI / 180.0)) << up->transpose();
  }

  s.http.reset();
  s.grpc.reset();
  s.map.reset();
  fs::remove_all(dir);
}

}  // namespace
}  // namespace loci::server
