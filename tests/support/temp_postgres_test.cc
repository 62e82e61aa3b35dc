// TempPostgres: a real server with PostGIS, independent databases, and nothing left running.
#include "tests/support/temp_postgres.h"

#include <gtest/gtest.h>
#include <libpq-fe.h>

#include <memory>
#include <string>

namespace loci::testing {
namespace {

using Conn = std::unique_ptr<PGconn, decltype(&PQfinish)>;
using Result = std::unique_ptr<PGresult, decltype(&PQclear)>;

Conn Connect(const std::string& uri) { return Conn(PQconnectdb(uri.c_str()), &PQfinish); }

// Runs `sql` and returns the first column of its first row ("" when it returns no rows).
std::string Query(PGconn* conn, const std::string& sql) {
  Result res(PQexec(conn, sql.c_str()), &PQclear);
  const ExecStatusType status = PQresultStatus(res.get());
  EXPECT_TRUE(status == PGRES_TUPLES_OK || status == PGRES_COMMAND_OK)
      << sql << ": " << PQerrorMessage(conn);
  if (status != PGRES_TUPLES_OK || PQntuples(res.get()) == 0) return "";
  return PQgetvalue(res.get(), 0, 0);
}

TEST(TempPostgresTest, DatabasesWithPostgisAndCleanShutdown) {
  if (!TempPostgres::Available()) {
    GTEST_SKIP() << "no PostgreSQL 15 server in " << TempPostgresOptions{}.bin_dir
                 << " (Debian: postgresql-15 postgresql-15-postgis-3)";
  }
  StatusOr<std::unique_ptr<TempPostgres>> pg = TempPostgres::Start();
  ASSERT_TRUE(pg.ok()) << pg.status();
  const int port = (*pg)->port();
  EXPECT_EQ((*pg)->Uri("a"), "postgresql://loci@127.0.0.1:" + std::to_string(port) + "/a");
  ASSERT_TRUE((*pg)->CreateDatabase("a").ok());
  ASSERT_TRUE((*pg)->CreateDatabase("b").ok());
  EXPECT_FALSE((*pg)->CreateDatabase("a").ok());  // exists already

  for (const std::string db : {"a", "b"}) {
    SCOPED_TRACE(db);
    Conn conn = Connect((*pg)->Uri(db));
    ASSERT_EQ(PQstatus(conn.get()), CONNECTION_OK) << PQerrorMessage(conn.get());
    EXPECT_EQ(Query(conn.get(), "SELECT current_database()"), db);
    Query(conn.get(), "CREATE EXTENSION postgis");
    EXPECT_FALSE(Query(conn.get(), "SELECT PostGIS_Version()").empty());
    // Same table name in both databases: each starts empty, so they do not share state.
    Query(conn.get(), "CREATE TABLE objects (id int PRIMARY KEY, label text, at geometry)");
    EXPECT_EQ(Query(conn.get(), "SELECT count(*) FROM objects"), "0");
    Query(conn.get(), "INSERT INTO objects VALUES (1, '" + db + "', ST_MakePoint(1, 2))");
    EXPECT_EQ(Query(conn.get(), "SELECT label || ' ' || ST_AsText(at) FROM objects WHERE id = 1"),
              db + " POINT(1 2)");
  }

  // The default database exists, and the server is gone once the object is.
  EXPECT_EQ(PQstatus(Connect((*pg)->Uri()).get()), CONNECTION_OK);
  pg->reset();
  const std::string conninfo = "host=127.0.0.1 port=" + std::to_string(port) + " user=loci";
  EXPECT_EQ(PQping(conninfo.c_str()), PQPING_NO_RESPONSE);
}

}  // namespace
}  // namespace loci::testing
