#include "client/streaming/map_client.h"

#include <grpcpp/grpcpp.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>

#include "client/streaming/keyframe_encoder.h"
#include "common/thread_name.h"
#include "loci/v1/mapping.grpc.pb.h"
#include "proto/convert.h"

namespace loci {

namespace {

// Waits until the server reports SERVING (a server that is still starting or loading its
// map), logging every 2 s.
Status WaitForServer(grpc::Channel& channel, const MapClientOptions& o) {
  const auto give_up = std::chrono::system_clock::now() +
                       std::chrono::milliseconds(static_cast<int64_t>(o.connect_timeout_s * 1e3));
  return WaitForServing(channel, give_up, [&](double waited_s, const std::string& health) {
    spdlog::info("waiting for loci-server at {} ({:.0f} s, {})", o.server, waited_s, health);
  });
}
using Clock = std::chrono::steady_clock;
std::chrono::system_clock::time_point DeadlineIn(double s) {
  return std::chrono::system_clock::now() +
         std::chrono::microseconds(static_cast<int64_t>(s * 1e6));
}
}  // namespace

struct MapClient::Impl {
  MapClientOptions opt;
  PinholeCamera camera;
  double depth_scale = 0;
  std::shared_ptr<grpc::Channel> channel;
  std::unique_ptr<v1::Mapping::Stub> stub;

  mutable std::mutex mu;
  std::condition_variable cv;
  std::string session_id;
  int64_t next_seq = 0;
  // Keyframes not yet acknowledged, by seq (raw until first written, then encoded).
  struct Entry {
    KeyframeData raw;
    std::shared_ptr<v1::Keyframe> encoded;
  };
  std::map<int64_t, Entry> unacked;
  bool closing = false;
  bool stop = false;
  bool sender_done = false;
  // The call the sender thread is in (stream or resume), so that Close can cancel it.
  grpc::ClientContext* active_call = nullptr;
  MapClientStats stats;
  std::thread sender;

  // Registers `ctx` as the active call while alive; a stopped client cancels it at once.
  class ActiveCall {
   public:
    ActiveCall(Impl* impl, grpc::ClientContext* ctx) : impl_(impl) {
      std::lock_guard<std::mutex> lock(impl_->mu);
      impl_->active_call = ctx;
      if (impl_->stop) ctx->TryCancel();
    }
    ~ActiveCall() {
      std::lock_guard<std::mutex> lock(impl_->mu);
      impl_->active_call = nullptr;
    }

   private:
    Impl* impl_;
  };

  // Stops the sender and cancels its call (a Write blocked by flow control, a resume). Needs mu.
  void StopLocked() {
    stop = true;
    if (active_call) active_call->TryCancel();
    cv.notify_all();
  }

  Status OpenSession(bool resume, int64_t* last_stored_seq) {
    v1::OpenSessionRequest req;
    req.set_robot_name(opt.robot_name);
    loci::ToProto(camera, req.mutable_intrinsics());
    req.set_depth_scale(depth_scale);
    req.set_client_version(opt.client_version);
    req.set_resume(resume);
    req.set_site(opt.site);
    v1::OpenSessionResponse resp;
    grpc::ClientContext ctx;
    ctx.set_deadline(DeadlineIn(opt.rpc_timeout_s));
    const ActiveCall active(this, &ctx);
    const grpc::Status s = stub->OpenSession(&ctx, req, &resp);
    if (!s.ok()) {
      return Status(static_cast<absl::StatusCode>(s.error_code()),
                    absl::StrCat("OpenSession: ", s.error_message()));
    }
    std::lock_guard<std::mutex> lock(mu);
    session_id = resp.session_id();
    *last_stored_seq = resp.last_stored_seq();
    return absl::OkStatus();
  }

  // Runs one stream until it breaks or the client closes with nothing left to send.
  // Returns true when finished cleanly (closing and all acked).
  bool RunStream() {
    grpc::ClientContext ctx;
    const ActiveCall active(this, &ctx);
    auto stream = stub->StreamKeyframes(&ctx);
    bool broken = false;
    std::thread reader([&] {
      v1::KeyframeAck ack;
      while (stream->Read(&ack)) {
        std::lock_guard<std::mutex> lock(mu);
        ++stats.acked;
        if (ack.duplicate()) ++stats.duplicates;
        if (ack.status().code() != 0) {
          // A rejection is final (the server never stores it): report, do not resend.
          ++stats.rejected;
          stats.last_error =
              absl::StrCat("keyframe ", ack.seq(), " rejected: ", ack.status().message());
          spdlog::warn("{}", stats.last_error);
        }
        unacked.erase(ack.seq());
        cv.notify_all();
      }
      std::lock_guard<std::mutex> lock(mu);
      broken = true;
      cv.notify_all();
    });
    int64_t last_written = -1;
    bool clean = false;
    while (true) {
      std::shared_ptr<v1::Keyframe> kf;
      int64_t seq = -1;
      {
        std::unique_lock<std::mutex> lock(mu);
        cv.wait(lock, [&] {
          return broken || stop || (closing && unacked.empty()) ||
                 unacked.upper_bound(last_written) != unacked.end();
        });
        if (broken || stop) break;
        if (closing && unacked.empty()) {
          clean = true;
          break;
        }
        auto it = unacked.upper_bound(last_written);
        seq = it->first;
        kf = it->second.encoded;
        if (!kf) {
          KeyframeData raw = it->second.raw;  // cv::Mat copies share pixels
          lock.unlock();
          auto enc = EncodeKeyframe(raw, seq, opt.jpeg_quality);
          lock.lock();
          if (!enc.ok()) {
            ++stats.rejected;
            stats.last_error = std::string(enc.status().message());
            spdlog::error("keyframe {} not encodable: {}", seq, stats.last_error);
            unacked.erase(seq);
            cv.notify_all();
            continue;
          }
          kf = std::make_shared<v1::Keyframe>(std::move(*enc));
          auto again = unacked.find(seq);
          if (again != unacked.end()) again->second.encoded = kf;
        }
        kf->set_session_id(session_id);
      }
      last_written = seq;
      if (!stream->Write(*kf)) break;
      std::lock_guard<std::mutex> lock(mu);
      stats.bytes_sent += static_cast<int64_t>(kf->ByteSizeLong());
    }
    if (clean) {
      stream->WritesDone();
    } else {
      ctx.TryCancel();
    }
    reader.join();
    const grpc::Status fin = stream->Finish();
    if (!clean && !fin.ok()) {
      std::lock_guard<std::mutex> lock(mu);
      stats.last_error = absl::StrCat("stream: ", fin.error_message());
    }
    return clean;
  }

  void SenderLoop() {
    SendUntilDone();
    std::lock_guard<std::mutex> lock(mu);
    sender_done = true;
    cv.notify_all();
  }

  void SendUntilDone() {
    double backoff_s = opt.initial_backoff_s;
    bool first = true;
    while (true) {
      {
        std::lock_guard<std::mutex> lock(mu);
        if (stop) return;
      }
      if (!first) {
        int64_t last_stored = -1;
        Status s = OpenSession(/*resume=*/true, &last_stored);
        if (!s.ok()) {
          std::unique_lock<std::mutex> lock(mu);
          stats.last_error = std::string(s.message());
          cv.wait_for(lock, std::chrono::duration<double>(backoff_s), [&] { return stop; });
          backoff_s = std::min(opt.max_backoff_s, backoff_s * 2);
          continue;
        }
        std::lock_guard<std::mutex> lock(mu);
        ++stats.reconnects;
        // Everything up to last_stored_seq is committed on the server.
        for (auto it = unacked.begin(); it != unacked.end() && it->first <= last_stored;) {
          ++stats.acked;
          ++stats.duplicates;
          it = unacked.erase(it);
        }
        cv.notify_all();
        spdlog::info("map client: resumed session {} (last stored seq {}), resending {}",
                     session_id, last_stored, unacked.size());
      }
      first = false;
      const auto started = Clock::now();
      if (RunStream()) return;
      // A stream that lived a while resets the back-off.
      if (Clock::now() - started > std::chrono::seconds(5)) backoff_s = opt.initial_backoff_s;
      std::unique_lock<std::mutex> lock(mu);
      spdlog::warn("map client: stream to {} broke ({}), reconnecting in {:.1f} s", opt.server,
                   stats.last_error, backoff_s);
      cv.wait_for(lock, std::chrono::duration<double>(backoff_s), [&] { return stop; });
      backoff_s = std::min(opt.max_backoff_s, backoff_s * 2);
    }
  }
};

MapClient::MapClient(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

StatusOr<std::unique_ptr<MapClient>> MapClient::Connect(const MapClientOptions& options,
                                                        const PinholeCamera& camera,
                                                        double depth_scale) {
  LOCI_RETURN_IF_ERROR(camera.Validate());
  if (options.max_unacked < 1 || options.initial_backoff_s <= 0 ||
      options.max_backoff_s < options.initial_backoff_s || options.rpc_timeout_s <= 0 ||
      options.server.empty() || options.robot_name.empty()) {
    return absl::InvalidArgumentError("map client options out of range");
  }
  auto impl = std::make_unique<Impl>();
  impl->opt = options;
  impl->camera = camera;
  impl->depth_scale = depth_scale;
  grpc::ChannelArguments args;
  args.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS, 100);
  args.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, 1000);
  args.SetMaxSendMessageSize(64 << 20);
  LOCI_ASSIGN_OR_RETURN(impl->channel, MakeChannel(options.server, options.security, args));
  impl->stub = v1::Mapping::NewStub(impl->channel);
  LOCI_RETURN_IF_ERROR(WaitForServer(*impl->channel, options));
  int64_t last_stored = -1;
  LOCI_RETURN_IF_ERROR(impl->OpenSession(/*resume=*/false, &last_stored));
  impl->next_seq = last_stored + 1;
  Impl* raw = impl.get();
  impl->sender = NamedThread("track-send", [raw] { raw->SenderLoop(); });
  return std::unique_ptr<MapClient>(new MapClient(std::move(impl)));
}

MapClient::~MapClient() {
  {
    std::lock_guard<std::mutex> lock(impl_->mu);
    impl_->StopLocked();
  }
  if (impl_->sender.joinable()) impl_->sender.join();
}

StatusOr<int64_t> MapClient::Send(KeyframeData keyframe) {
  std::unique_lock<std::mutex> lock(impl_->mu);
  if (impl_->closing || impl_->stop) return absl::UnavailableError("map client is closed");
  impl_->cv.wait(lock, [&] {
    return static_cast<int>(impl_->unacked.size()) < impl_->opt.max_unacked || impl_->stop;
  });
  if (impl_->stop) return absl::UnavailableError("map client is closed");
  const int64_t seq = impl_->next_seq++;
  impl_->unacked[seq].raw = std::move(keyframe);
  ++impl_->stats.queued;
  impl_->cv.notify_all();
  return seq;
}

Status MapClient::Close(double timeout_s) {
  const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                           std::chrono::duration<double>(timeout_s));
  std::unique_lock<std::mutex> lock(impl_->mu);
  impl_->closing = true;
  impl_->cv.notify_all();
  const bool all = impl_->cv.wait_until(lock, deadline, [&] { return impl_->unacked.empty(); });
  const size_t left = impl_->unacked.size();
  // The sender ends its stream once everything is acknowledged; at the deadline, whatever it
  // is blocked in (a Write the server does not read, a resume) is cancelled.
  if (!impl_->cv.wait_until(lock, deadline, [&] { return impl_->sender_done; })) {
    impl_->StopLocked();
  }
  lock.unlock();
  if (impl_->sender.joinable()) impl_->sender.join();
  if (!all) {  // the session stays open: a later client may resume it
    return absl::DeadlineExceededError(
        absl::StrCat(left, " keyframes not acknowledged within ", timeout_s, " s"));
  }
  v1::CloseSessionRequest req;
  req.set_session_id(session_id());
  v1::CloseSessionResponse resp;
  grpc::ClientContext ctx;
  ctx.set_deadline(std::min(DeadlineIn(impl_->opt.rpc_timeout_s),
                            std::chrono::system_clock::now() + (deadline - Clock::now())));
  const grpc::Status s = impl_->stub->CloseSession(&ctx, req, &resp);
  if (!s.ok()) return absl::UnavailableError(absl::StrCat("CloseSession: ", s.error_message()));
  return absl::OkStatus();
}

MapClientStats MapClient::stats() const {
  std::lock_guard<std::mutex> lock(impl_->mu);
  return impl_->stats;
}

std::string MapClient::session_id() const {
  std::lock_guard<std::mutex> lock(impl_->mu);
  return impl_->session_id;
}

int64_t MapClient::unacked() const {
  std::lock_guard<std::mutex> lock(impl_->mu);
  return static_cast<int64_t>(impl_->unacked.size());
}

}  // namespace loci
