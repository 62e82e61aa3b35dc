#include "common/time.h"

#include <gtest/gtest.h>

#include <vector>

namespace loci {
namespace {

TEST(Time, ParsesTumStampsExactly) {
  EXPECT_EQ(*ParseSecondsToNs("1305031229.528784"), 1305031229528784000LL);
  EXPECT_EQ(*ParseSecondsToNs("1305031225.9334"), 1305031225933400000LL);
  EXPECT_EQ(*ParseSecondsToNs("12"), 12000000000LL);
  EXPECT_EQ(*ParseSecondsToNs("0.000000001"), 1);
  EXPECT_FALSE(ParseSecondsToNs("abc").ok());
  EXPECT_FALSE(ParseSecondsToNs("12.x").ok());
  EXPECT_FALSE(ParseSecondsToNs("").ok());
}

TEST(Time, FormatsLikeTum) {
  EXPECT_EQ(FormatNsAsSeconds(1305031229528784000LL), "1305031229.528784");
  EXPECT_EQ(FormatNsAsSeconds(1000), "0.000001");
}

struct Stamped {
  int64_t t_ns;
};

TEST(Time, NearestByTimeWithinTolerance) {
  const std::vector<Stamped> v{{100}, {200}, {300}};
  EXPECT_EQ(NearestByTime<Stamped>(v, 140, 50)->t_ns, 100);
  EXPECT_EQ(NearestByTime<Stamped>(v, 160, 50)->t_ns, 200);
  EXPECT_EQ(NearestByTime<Stamped>(v, 150, 50)->t_ns, 200);  // a tie goes to the later one
  EXPECT_EQ(NearestByTime<Stamped>(v, 0, 100)->t_ns, 100);
  EXPECT_EQ(NearestByTime<Stamped>(v, 390, 100)->t_ns, 300);
  EXPECT_EQ(NearestByTime<Stamped>(v, 300, 0)->t_ns, 300);
  EXPECT_EQ(NearestByTime<Stamped>(v, 250, 49), nullptr);
  EXPECT_EQ(NearestByTime<Stamped>(v, 401, 100), nullptr);
  EXPECT_EQ(NearestByTime<Stamped>({}, 100, 100), nullptr);
}

TEST(Time, ThreadCpuMsCountsThisThreadsWork) {
  const double t0 = ThreadCpuMs();
  volatile double x = 0;
  for (int i = 0; i < 20'000'000; ++i) x = x + 1e-9 * i;
  EXPECT_GT(ThreadCpuMs(), t0);
}

}  // namespace
}  // namespace loci
