#include "tests/server/island_robots.h"

#include <absl/strings/str_cat.h>
#include <grpcpp/create_channel.h>
#include <gtest/gtest.h>

#include "proto/convert.h"
#include "server/runtime/proto_convert.h"
#include "server/service/query_adapter.h"
#include "tests/server/keyframe_proto.h"

namespace loci::server::testing {

synth::SceneOptions Room(uint64_t seed, int num_frames) {
  synth::SceneOptions o;
  o.seed = seed;
  o.num_frames = num_frames;
  o.fps_hz = 5.0;
  o.num_objects = 8;
  return o;
}

ServerOptions Options() {
  ServerOptions o;
  EXPECT_TRUE(o.FromYamlFile(std::string(LOCI_SOURCE_DIR) + "/config/server.yaml").ok());
  o.map.cloud.max_depth_m = 6.0;
  o.map.octomap.max_range_m = 6.0;
  return o;
}

Running Start(const std::string& db, bool loops) {
  ServerOptions o = Options();
  o.align.loops.enabled = loops;
  return Start(db, o);
}

Running Start(const std::string& db, ServerOptions o) {
  o.db_path = db;
  Running r;
  auto server = MapServer::Open(o);
  EXPECT_TRUE(server.ok()) << server.status();
  if (!server.ok()) return r;
  r.server = std::move(*server);
  auto grpc = GrpcServer::Start(r.server.get(), "127.0.0.1:0", 64,
                                std::make_shared<QueryAdapter>(QueryAdapterOptions{}));
  EXPECT_TRUE(grpc.ok()) << grpc.status();
  if (!grpc.ok()) return r;
  r.grpc = std::move(*grpc);
  auto channel = grpc::CreateChannel(absl::StrCat("127.0.0.1:", r.grpc->port()),
                                     grpc::InsecureChannelCredentials());
  r.mapping = loci::v1::Mapping::NewStub(channel);
  r.query = loci::v1::Query::NewStub(channel);
  return r;
}

std::vector<loci::v1::Keyframe> Rebased(const std::vector<loci::v1::Keyframe>& views, size_t first,
                                        bool own_odometry) {
  const SE3d T_odom_world =
      own_odometry ? PoseFromProto(views[first].t_odom_cam()).inverse() : SE3d::Identity();
  std::vector<loci::v1::Keyframe> out(views.begin() + static_cast<std::ptrdiff_t>(first),
                                      views.end());
  for (loci::v1::Keyframe& kf : out) {
    ToProto(T_odom_world * PoseFromProto(kf.t_odom_cam()), kf.mutable_t_odom_cam());
  }
  return out;
}

std::string Stream(loci::v1::Mapping::Stub* stub, const std::string& robot,
                   const std::vector<loci::v1::Keyframe>& keyframes) {
  grpc::ClientContext open_ctx;
  loci::v1::OpenSessionResponse session;
  EXPECT_TRUE(stub->OpenSession(&open_ctx,
                                testing::OpenRequest(robot, PinholeCamera::TumFr1(), false),
                                &session)
                  .ok());
  StreamInto(stub, session.session_id(), keyframes, 0);
  return session.session_id();
}

void StreamInto(loci::v1::Mapping::Stub* stub, const std::string& session_id,
                const std::vector<loci::v1::Keyframe>& keyframes, int64_t first_seq) {
  grpc::ClientContext ctx;
  auto stream = stub->StreamKeyframes(&ctx);
  for (size_t i = 0; i < keyframes.size(); ++i) {
    loci::v1::Keyframe kf = keyframes[i];
    kf.set_session_id(session_id);
    kf.set_seq(first_seq + static_cast<int64_t>(i));
    EXPECT_TRUE(stream->Write(kf));
    loci::v1::KeyframeAck ack;
    EXPECT_TRUE(stream->Read(&ack));
    EXPECT_EQ(ack.status().code(), 0) << ack.status().message();
  }
  stream->WritesDone();
  EXPECT_TRUE(stream->Finish().ok());
}

loci::v1::GetStatsResponse Stats(loci::v1::Query::Stub* stub) {
  grpc::ClientContext ctx;
  loci::v1::GetStatsResponse resp;
  EXPECT_TRUE(stub->GetStats(&ctx, {}, &resp).ok());
  return resp;
}

std::map<std::string, loci::v1::SessionAlignment> SessionsByRobot(
    const loci::v1::GetStatsResponse& stats) {
  std::map<std::string, loci::v1::SessionAlignment> out;
  for (const auto& s : stats.session_alignments()) out[s.robot()] = s;
  return out;
}

}  // namespace loci::server::testing
