#include "server/http/event_stream.h"

#include "common/time.h"
#include "proto/json.h"
#include "server/http/http_reply.h"
#include "server/service/services.h"

// Last: httplib pulls <resolv.h>, whose `_res` macro breaks Eigen headers included after it.
#include <httplib.h>

namespace loci::server {
namespace {

constexpr size_t kQueueEvents = 1024;

bool Write(httplib::DataSink& sink, const std::string& text) {
  return sink.write(text.data(), text.size());
}

std::string ObjectEventText(const ObjectEventOut& e) {
  loci::v1::ObjectEvent msg;
  ToProto(e, NowNs(), &msg);
  return "event: object\ndata: " + ProtoToJson(msg) + "\n\n";
}

}  // namespace

// Holds a stream's subscription and its client slot; released when the response (and with it
// the content provider holding this) is gone, whatever ended the stream.
struct EventStreams::Slot {
  Slot(EventStreams* owner, std::shared_ptr<ObjectEventQueue> q) : streams(owner), queue(q) {}
  ~Slot() {
    if (subscribed) streams->service_->UnsubscribeObjects(queue);
    --streams->open_;
  }
  EventStreams* streams;
  std::shared_ptr<ObjectEventQueue> queue;
  bool subscribed = false;
};

bool EventStreams::Acquire() {
  int open = open_.load();
  while (open < max_) {
    if (open_.compare_exchange_weak(open, open + 1)) return true;
  }
  return false;
}

void EventStreams::Serve(const httplib::Request&, httplib::Response& res) {
  if (!Acquire()) {
    return SendError(res, absl::UnavailableError(absl::StrCat(
                              "already ", max_, " event streams open (server.max_event_clients)")));
  }
  auto slot = std::make_shared<Slot>(this, std::make_shared<ObjectEventQueue>(kQueueEvents));
  if (Status s = service_->SubscribeObjects(slot->queue); !s.ok()) {
    return SendError(res, absl::UnavailableError(s.message()));
  }
  slot->subscribed = true;
  res.set_header("Cache-Control", "no-cache");
  res.set_header("X-Accel-Buffering", "no");
  res.set_chunked_content_provider(
      "text/event-stream", [this, slot](size_t, httplib::DataSink& sink) {
        if (!Pump(*slot->queue, sink)) return false;
        sink.done();
        return true;
      });
}

bool EventStreams::Pump(ObjectEventQueue& queue, httplib::DataSink& sink) {
  using Clock = std::chrono::steady_clock;
  if (!Write(sink, "retry: 2000\nevent: ready\ndata: {}\n\n")) return false;
  Clock::time_point last_write = Clock::now();
  while (!stopping_) {
    if (std::optional<ObjectEventOut> e = queue.PopFor(kPoll)) {
      if (!Write(sink, ObjectEventText(*e))) return false;
      last_write = Clock::now();
    } else if (Clock::now() - last_write >= kKeepAlive) {
      if (!Write(sink, ": keep-alive\n\n")) return false;
      last_write = Clock::now();
    }
  }
  return true;
}

}  // namespace loci::server
