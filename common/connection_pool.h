// A bounded pool of database connections: at most `max_idle` stay open between uses. A thread
// that finds none idle opens one, and a connection returned to a full pool is closed, so the
// count stays bounded however many threads read. `Conn` is a handle (sqlite3*, PGconn*) that the
// pool's closer frees.
#pragma once

#include <cstddef>
#include <functional>
#include <mutex>
#include <utility>
#include <vector>

#include "common/status.h"

namespace loci {

template <typename Conn>
class ConnectionPool {
 public:
  using Opener = std::function<StatusOr<Conn>()>;
  using Closer = std::function<void(Conn)>;
  ConnectionPool(Opener open, Closer close, size_t max_idle)
      : open_(std::move(open)), close_(std::move(close)), max_idle_(max_idle) {}
  ~ConnectionPool() {
    for (Conn c : idle_) close_(c);
  }
  ConnectionPool(const ConnectionPool&) = delete;
  ConnectionPool& operator=(const ConnectionPool&) = delete;

  // A connection for the lifetime of the lease.
  class Lease {
   public:
    Lease(ConnectionPool* pool, Conn conn) : pool_(pool), conn_(conn), held_(true) {}
    Lease(Lease&& other) noexcept : pool_(other.pool_), conn_(other.conn_), held_(other.held_) {
      other.held_ = false;
    }
    Lease& operator=(Lease&&) = delete;
    ~Lease() {
      if (held_) pool_->Release(conn_);
    }
    Conn get() const { return conn_; }
    // Closes the connection instead of returning it (it broke).
    void Discard() {
      if (held_) pool_->Drop(conn_);
      held_ = false;
    }

   private:
    ConnectionPool* pool_;
    Conn conn_;
    bool held_;
  };

  StatusOr<Lease> Acquire() {
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (!idle_.empty()) {
        Conn c = idle_.back();
        idle_.pop_back();
        ++leased_;
        return Lease(this, c);
      }
    }
    LOCI_ASSIGN_OR_RETURN(Conn c, open_());
    std::lock_guard<std::mutex> lock(mu_);
    ++leased_;
    return Lease(this, c);
  }

  // Connections open now: leased plus idle.
  size_t open_count() const {
    std::lock_guard<std::mutex> lock(mu_);
    return leased_ + idle_.size();
  }

 private:
  void Release(Conn c) {
    std::unique_lock<std::mutex> lock(mu_);
    --leased_;
    if (idle_.size() < max_idle_) {
      idle_.push_back(c);
      return;
    }
    lock.unlock();
    close_(c);
  }
  void Drop(Conn c) {
    {
      std::lock_guard<std::mutex> lock(mu_);
      --leased_;
    }
    close_(c);
  }

  Opener open_;
  Closer close_;
  const size_t max_idle_;
  mutable std::mutex mu_;
  std::vector<Conn> idle_;  // guarded by mu_
  size_t leased_ = 0;       // guarded by mu_
};

}  // namespace loci
