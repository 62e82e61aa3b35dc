// GET /api/events: the WatchObjects events as Server-Sent Events (text/event-stream), for the web
// viewer. A stream opens with `event: ready` once it is subscribed (every later object change
// arrives), then sends `event: object` with an ObjectEvent as proto3 JSON per change and a
// `: keep-alive` comment every second when idle. A client that goes away is noticed at the next
// write (within about a second), its thread and subscription freed. At most `max_clients`
// streams are open at once; more are answered 503 UNAVAILABLE.
#pragma once

#include <atomic>
#include <chrono>
#include <memory>

#include "server/service/query_api.h"

namespace httplib {
struct Request;
struct Response;
class DataSink;
}  // namespace httplib

namespace loci::server {

class EventStreams {
 public:
  EventStreams(QueryApi* service, int max_clients) : service_(service), max_(max_clients) {}

  void Serve(const httplib::Request& req, httplib::Response& res);
  // Ends every open stream within one poll interval (the HTTP server's shutdown).
  void Stop() { stopping_ = true; }
  int open_streams() const { return open_; }

  static constexpr std::chrono::milliseconds kPoll{200};
  static constexpr std::chrono::milliseconds kKeepAlive{1000};

 private:
  struct Slot;  // one open stream: its subscription and its place among max_clients
  bool Acquire();
  // Writes events to `sink` until the client leaves or Stop(); false when a write failed.
  bool Pump(ObjectEventQueue& queue, httplib::DataSink& sink);

  QueryApi* const service_;
  const int max_;
  std::atomic<int> open_{0};
  std::atomic<bool> stopping_{false};
};

}  // namespace loci::server
