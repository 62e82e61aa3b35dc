// Read connections of the SQLite store: at most `max_idle` stay open between uses. A thread that
// finds none idle opens one, and a connection returned to a full pool is closed, so the count
// stays bounded however many threads read (the store's old one-per-thread-id map grew forever).
#pragma once

#include <sqlite3.h>

#include <cstddef>
#include <functional>
#include <mutex>
#include <vector>

#include "common/status.h"

namespace loci::server::sqlite {

class ReadPool {
 public:
  using Opener = std::function<StatusOr<sqlite3*>()>;
  ReadPool(Opener open, size_t max_idle) : open_(std::move(open)), max_idle_(max_idle) {}
  ~ReadPool();
  ReadPool(const ReadPool&) = delete;
  ReadPool& operator=(const ReadPool&) = delete;

  // A connection for the lifetime of the lease.
  class Lease {
   public:
    Lease(ReadPool* pool, sqlite3* db) : pool_(pool), db_(db) {}
    Lease(Lease&& other) noexcept : pool_(other.pool_), db_(other.db_) { other.db_ = nullptr; }
    Lease& operator=(Lease&&) = delete;
    ~Lease() {
      if (db_) pool_->Release(db_);
    }
    sqlite3* get() const { return db_; }

   private:
    ReadPool* pool_;
    sqlite3* db_;
  };

  StatusOr<Lease> Acquire();
  // Connections open now: leased plus idle.
  size_t open_count() const;

 private:
  void Release(sqlite3* db);

  Opener open_;
  const size_t max_idle_;
  mutable std::mutex mu_;
  std::vector<sqlite3*> idle_;  // guarded by mu_
  size_t leased_ = 0;           // guarded by mu_
};

}  // namespace loci::server::sqlite
