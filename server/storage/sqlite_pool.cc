#include "server/storage/sqlite_pool.h"

namespace loci::server::sqlite {

ReadPool::~ReadPool() {
  for (sqlite3* db : idle_) sqlite3_close_v2(db);
}

StatusOr<ReadPool::Lease> ReadPool::Acquire() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (!idle_.empty()) {
      sqlite3* db = idle_.back();
      idle_.pop_back();
      ++leased_;
      return Lease(this, db);
    }
  }
  LOCI_ASSIGN_OR_RETURN(sqlite3 * db, open_());
  std::lock_guard<std::mutex> lock(mu_);
  ++leased_;
  return Lease(this, db);
}

void ReadPool::Release(sqlite3* db) {
  std::lock_guard<std::mutex> lock(mu_);
  --leased_;
  if (idle_.size() < max_idle_) {
    idle_.push_back(db);
  } else {
    sqlite3_close_v2(db);
  }
}

size_t ReadPool::open_count() const {
  std::lock_guard<std::mutex> lock(mu_);
  return leased_ + idle_.size();
}

}  // namespace loci::server::sqlite
