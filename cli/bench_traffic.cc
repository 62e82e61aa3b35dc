#include "cli/bench_traffic.h"

#include <chrono>
#include <thread>

#include "cli/bench_views.h"
#include "loci/v1/mapping.grpc.pb.h"
#include "loci/v1/query.grpc.pb.h"

namespace loci::cli {

using Clock = std::chrono::steady_clock;

void RobotLoop(const std::shared_ptr<grpc::Channel>& channel, const std::string& robot,
               const std::string& site, const std::vector<loci::v1::Keyframe>& views,
               double robot_hz, const std::atomic<bool>& stop, std::atomic<uint64_t>* acked,
               std::atomic<uint64_t>* errors) {
  auto stub = loci::v1::Mapping::NewStub(channel);
  grpc::ClientContext open_ctx;
  loci::v1::OpenSessionRequest req = BenchOpenRequest(robot, 5000.0);
  req.set_site(site);
  loci::v1::OpenSessionResponse session;
  if (!stub->OpenSession(&open_ctx, req, &session).ok()) {
    ++*errors;
    return;
  }
  grpc::ClientContext ctx;
  auto stream = stub->StreamKeyframes(&ctx);
  std::thread reader([&] {
    loci::v1::KeyframeAck ack;
    while (stream->Read(&ack)) ack.status().code() == 0 ? ++*acked : ++*errors;
  });
  const auto period = std::chrono::duration<double>(robot_hz > 0 ? 1.0 / robot_hz : 0.0);
  auto next = Clock::now();
  for (int64_t i = 0; !stop; ++i) {
    if (!stream->Write(NthKeyframe(views, i, session.session_id()))) break;
    next += std::chrono::duration_cast<Clock::duration>(period);
    std::this_thread::sleep_until(next);  // pacing of a robot's keyframe rate
  }
  stream->WritesDone();
  reader.join();
  if (!stream->Finish().ok()) ++*errors;
}

void ClientLoop(const std::shared_ptr<grpc::Channel>& channel, double client_hz, bool find_only,
                const std::atomic<bool>& stop, Latencies* out) {
  auto stub = loci::v1::Query::NewStub(channel);
  static const char* kQuestions[] = {"where is the cup", "what is on the table",
                                     "how many laptops are there", "list all objects"};
  const auto period = std::chrono::duration<double>(client_hz > 0 ? 1.0 / client_hz : 0.0);
  auto next = Clock::now();
  for (int i = find_only ? 1 : 0; !stop; i += find_only ? 2 : 1) {
    next += std::chrono::duration_cast<Clock::duration>(period);
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
    const auto t0 = Clock::now();
    grpc::Status s;
    if (i % 2 == 0) {
      loci::v1::AskRequest req;
      req.set_text(kQuestions[(i / 2) % 4]);
      loci::v1::AskResponse resp;
      s = stub->Ask(&ctx, req, &resp);
    } else {
      loci::v1::FindObjectsResponse resp;
      s = stub->FindObjects(&ctx, loci::v1::FindObjectsRequest(), &resp);
    }
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    // INVALID_ARGUMENT is an answer ("no cup in the map" on an empty map), not a failure.
    if (!s.ok() && s.error_code() != grpc::StatusCode::INVALID_ARGUMENT) ++out->errors;
    {
      std::lock_guard<std::mutex> lock(out->mu);
      (i % 2 == 0 ? out->ask_ms : out->find_ms).push_back(ms);
    }
    std::this_thread::sleep_until(next);  // pacing of a client's calls (none when unpaced)
  }
}

}  // namespace loci::cli
