// `loci bench merge`: a robot that starts anywhere in the same synthetic room is
// aligned to the shared map, exactly; a robot in another room rendered by the same generator
// (the same furniture and classes, other textures and layout: a look-alike, different place)
// is never merged, although place recognition finds candidates there; a robot behind a backlog
// is aligned ahead of it. Each run is a real
// in-process server on loopback gRPC (cli/bench_merge_cmd.cc).
#include <gtest/gtest.h>

#include <cstdio>
#include <regex>
#include <string>

namespace {

std::string RunBenchMerge(const std::string& args) {
  const std::string cmd = std::string(LOCI_BIN) + " bench merge " + args + " 2>/dev/null";
  FILE* p = popen(cmd.c_str(), "r");
  if (p == nullptr) return {};
  std::string out;
  char buf[4096];
  while (size_t n = fread(buf, 1, sizeof buf, p)) out.append(buf, n);
  EXPECT_EQ(pclose(p), 0) << cmd << "\n" << out;
  return out;
}

double Number(const std::string& out, const std::string& pattern) {
  std::smatch m;
  if (!std::regex_search(out, m, std::regex(pattern))) return -1;
  return std::stod(m[1]);
}

// In order: B's 20 keyframes sent at once can form a backlog on a loaded machine, and then its
// newest one, queried ahead, completes the consensus (the next test) and the count below is its.
TEST(BenchMerge, RobotStartingAnywhereInTheSameRoomIsAlignedExactly) {
  const std::string out =
      RunBenchMerge("--views 40 --start 20 --robot-hz 0 --query-ahead-backlog 0");
  ASSERT_EQ(out.find("NOT aligned"), std::string::npos) << out;
  const double error_mm = Number(out, R"(alignment error against the truth: ([0-9.]+) mm)");
  const double error_deg = Number(out, R"(against the truth: [0-9.]+ mm, ([0-9.]+) deg)");
  ASSERT_GE(error_mm, 0) << out;
  EXPECT_LT(error_mm, 10.0) << out;
  EXPECT_LT(error_deg, 0.5) << out;
  EXPECT_LE(Number(out, R"(aligned after ([0-9]+) keyframes of B)"), 5) << out;
}

// B first streams 120 keyframes of another room, unpaced: the mapping worker and place
// recognition fall behind, and B's keyframes in A's room queue behind that backlog. Its newest
// keyframes are recognised ahead of it (align.query_ahead_backlog), and the placement is as exact
// as without a backlog.
TEST(BenchMerge, RobotBehindABacklogIsAlignedAheadOfIt) {
  const std::string out = RunBenchMerge("--views 40 --start 20 --held 120");
  ASSERT_EQ(out.find("NOT aligned"), std::string::npos) << out;
  EXPECT_GE(Number(out, R"(place recognition when it was sent: ([0-9]+))"), 8) << out;
  EXPECT_EQ(Number(out, R"(merges accepted \(([0-9]+) of them ahead of the backlog)"), 1) << out;
  EXPECT_LT(Number(out, R"(alignment error against the truth: ([0-9.]+) mm)"), 10.0) << out;
  EXPECT_LT(Number(out, R"(against the truth: [0-9.]+ mm, ([0-9.]+) deg)"), 0.5) << out;
}

TEST(BenchMerge, LookAlikeRoomElsewhereIsNeverMerged) {
  const std::string out = RunBenchMerge("--views 40 --start 0 --robot-hz 0 --other-room 8");
  EXPECT_NE(out.find("B was NOT aligned (40 keyframes stored)"), std::string::npos) << out;
  EXPECT_GT(Number(out, R"(its island map holds ([0-9]+) confirmed objects)"), 0) << out;
  EXPECT_EQ(Number(out, R"(; ([0-9]+) merges accepted)"), 0) << out;
  EXPECT_GT(Number(out, R"(verified, ([0-9]+) rejected candidates)"), 0)
      << "place recognition should find look-alike candidates for verification to reject\n"
      << out;
}

}  // namespace
