#include "tests/server/grpc_stream.h"

#include <gtest/gtest.h>
#include <signal.h>

#include <thread>

#include "server/runtime/proto_convert.h"
#include "tests/server/keyframe_proto.h"

namespace loci::server::testing {

std::string OpenSessionOn(loci::v1::Mapping::Stub* stub, const std::string& robot, bool resume,
                          int64_t* last, const std::string& site) {
  grpc::ClientContext ctx;
  loci::v1::OpenSessionRequest req = OpenRequest(robot, PinholeCamera::TumFr1(), resume);
  req.set_site(site);
  loci::v1::OpenSessionResponse resp;
  const grpc::Status s = stub->OpenSession(&ctx, req, &resp);
  EXPECT_TRUE(s.ok()) << s.error_message();
  if (last) *last = resp.last_stored_seq();
  return resp.session_id();
}

std::vector<loci::v1::KeyframeAck> StreamAcked(loci::v1::Mapping::Stub* stub,
                                               const std::string& session,
                                               const std::vector<loci::v1::Keyframe>& keyframes,
                                               int begin, int end) {
  grpc::ClientContext ctx;
  auto stream = stub->StreamKeyframes(&ctx);
  std::vector<loci::v1::KeyframeAck> acks;
  for (int i = begin; i < end; ++i) {
    loci::v1::Keyframe kf = keyframes[i];
    kf.set_session_id(session);
    if (!stream->Write(kf)) break;
    loci::v1::KeyframeAck ack;
    if (!stream->Read(&ack)) break;
    acks.push_back(ack);
  }
  stream->WritesDone();
  stream->Finish();
  return acks;
}

void StreamAndKill(loci::v1::Mapping::Stub* stub, const std::string& session,
                   const std::vector<loci::v1::Keyframe>& keyframes, int begin, int end,
                   int kill_at, loci::testing::ServerProcess* server, std::set<int64_t>* acked) {
  grpc::ClientContext ctx;
  auto stream = stub->StreamKeyframes(&ctx);
  std::thread reader([&] {
    loci::v1::KeyframeAck ack;
    while (stream->Read(&ack)) {
      if (ack.status().code() == 0) acked->insert(ack.seq());
    }
  });
  for (int i = begin; i < end; ++i) {
    loci::v1::Keyframe kf = keyframes[i];
    kf.set_session_id(session);
    if (!stream->Write(kf)) break;
    if (i == kill_at) server->Stop(SIGKILL);
  }
  stream->WritesDone();
  reader.join();
  stream->Finish();
}

std::vector<MapObject> ConfirmedObjects(loci::v1::Query::Stub* stub) {
  grpc::ClientContext ctx;
  loci::v1::FindObjectsRequest req;
  req.set_confirmed_only(true);
  loci::v1::FindObjectsResponse resp;
  EXPECT_TRUE(stub->FindObjects(&ctx, req, &resp).ok());
  std::vector<MapObject> out;
  for (const auto& o : resp.objects()) out.push_back(FromProto(o));
  return out;
}

}  // namespace loci::server::testing
