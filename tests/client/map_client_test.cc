// MapClient against an in-process Mapping service that opens sessions but never reads a
// keyframe: the client's Writes block on HTTP/2 flow control, and Close must still return at its
// deadline.
#include "client/streaming/map_client.h"

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <opencv2/core.hpp>

#include "loci/v1/mapping.grpc.pb.h"

namespace loci {
namespace {

class StalledMapping final : public v1::Mapping::Service {
 public:
  grpc::Status OpenSession(grpc::ServerContext*, const v1::OpenSessionRequest*,
                           v1::OpenSessionResponse* resp) override {
    resp->set_session_id("stalled-1");
    resp->set_last_stored_seq(-1);
    return grpc::Status::OK;
  }
  // Holds the stream without reading until the client cancels it or the server shuts down.
  grpc::Status StreamKeyframes(grpc::ServerContext* ctx,
                               grpc::ServerReaderWriter<v1::KeyframeAck, v1::Keyframe>*) override {
    std::unique_lock<std::mutex> lock(mu_);
    ++streams_;
    cv_.notify_all();
    while (!ctx->IsCancelled() && !shutdown_) cv_.wait_for(lock, std::chrono::milliseconds(20));
    ++cancelled_;
    cv_.notify_all();
    return grpc::Status::CANCELLED;
  }
  void WaitForStream() {
    std::unique_lock<std::mutex> lock(mu_);
    cv_.wait(lock, [&] { return streams_ > 0; });
  }
  // True once the held stream has ended (cancelled by the client), waiting up to `timeout`.
  bool WaitForCancel(std::chrono::seconds timeout) {
    std::unique_lock<std::mutex> lock(mu_);
    return cv_.wait_for(lock, timeout, [&] { return cancelled_ > 0; });
  }
  void Shutdown() {
    std::lock_guard<std::mutex> lock(mu_);
    shutdown_ = true;
  }

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  int streams_ = 0, cancelled_ = 0;
  bool shutdown_ = false;
};

// A keyframe of noise: neither JPEG nor PNG compresses it (about 1.5 MB on the wire).
KeyframeData NoiseKeyframe(int64_t t_ns) {
  KeyframeData kf;
  kf.t_ns = t_ns;
  kf.bgr = cv::Mat(480, 640, CV_8UC3);
  cv::randu(kf.bgr, cv::Scalar::all(0), cv::Scalar::all(255));
  kf.depth_u16 = cv::Mat(480, 640, CV_16UC1);
  cv::randu(kf.depth_u16, cv::Scalar(500), cv::Scalar(20000));
  return kf;
}

TEST(MapClientClose, ReturnsAtItsDeadlineWhileAWriteIsBlocked) {
  StalledMapping service;
  int port = 0;
  grpc::ServerBuilder builder;
  builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
  // Small HTTP/2 windows that never grow: the client's Writes stall after a few kB.
  builder.AddChannelArgument(GRPC_ARG_HTTP2_BDP_PROBE, 0);
  builder.AddChannelArgument(GRPC_ARG_HTTP2_STREAM_LOOKAHEAD_BYTES, 16 * 1024);
  builder.RegisterService(&service);
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  ASSERT_GT(port, 0);

  MapClientOptions o;
  o.server = "127.0.0.1:" + std::to_string(port);
  o.max_unacked = 8;
  auto client = MapClient::Connect(o, PinholeCamera::TumFr1(), 5000.0);
  ASSERT_TRUE(client.ok()) << client.status();
  for (int i = 0; i < 8; ++i) ASSERT_TRUE((*client)->Send(NoiseKeyframe(i + 1)).ok());
  service.WaitForStream();

  // The server never acks: Close gives up at its deadline and says what was not acknowledged.
  const Status closed = (*client)->Close(/*timeout_s=*/1.0);
  EXPECT_EQ(closed.code(), absl::StatusCode::kDeadlineExceeded) << closed;
  EXPECT_NE(closed.message().find("8 keyframes not acknowledged"), std::string::npos) << closed;
  EXPECT_TRUE(service.WaitForCancel(std::chrono::seconds(10)));  // the server saw the cancel
  EXPECT_EQ((*client)->stats().acked, 0);
  service.Shutdown();
  server->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(2));
}

}  // namespace
}  // namespace loci
