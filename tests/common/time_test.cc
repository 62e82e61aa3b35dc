#include "common/time.h"

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace loci
