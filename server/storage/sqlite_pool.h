// Read connections of the SQLite store (common/connection_pool.h): bounded however many threads
// read.
#pragma once

#include <sqlite3.h>

#include "common/connection_pool.h"

namespace loci::server::sqlite {

using ReadPool = ConnectionPool<sqlite3*>;

}  // namespace loci::server::sqlite
