// The colour bar's labels: round values inside the mapped range.

#include "palette.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace piperun::ui {
namespace {

void expectTicks(const std::vector<double>& ticks, const std::vector<double>& expected) {
  ASSERT_EQ(ticks.size(), expected.size());
  for (std::size_t i = 0; i < ticks.size(); ++i) EXPECT_NEAR(ticks[i], expected[i], 1e-12) << "tick " << i;
}

TEST(RoundTicks, RoundMultiplesInsideTheRange) {
  expectTicks(roundTicks(-0.00821, 4.0, 6), {0, 1, 2, 3, 4});  // a scene's heights
  expectTicks(roundTicks(0.0, 1.0, 6), {0, 0.2, 0.4, 0.6, 0.8, 1.0});  // confidence
  expectTicks(roundTicks(0.0, 0.02, 6), {0, 0.005, 0.01, 0.015, 0.02});  // the QA reach
  expectTicks(roundTicks(0.0152, 0.2032, 6), {0.05, 0.1, 0.15, 0.2});  // pipe radii
  expectTicks(roundTicks(-3.7, -1.2, 6), {-3.5, -3.0, -2.5, -2.0, -1.5});
  expectTicks(roundTicks(1.2, 1.3, 6), {1.2, 1.22, 1.24, 1.26, 1.28, 1.3});
}

TEST(RoundTicks, NeverMoreThanAskedAndNoNegativeZero) {
  for (const double high : {0.9, 1.7, 3.3, 12.0, 47.0, 999.0}) {
    const std::vector<double> ticks = roundTicks(-0.01, high, 6);
    EXPECT_LE(ticks.size(), 6u) << high;
    EXPECT_GE(ticks.size(), 2u) << high;
    EXPECT_FALSE(std::signbit(ticks.front())) << "a tick at -0 for high " << high;
  }
}

TEST(RoundTicks, AnEmptyOrUndefinedRangeKeepsItsEnds) {
  expectTicks(roundTicks(2.5, 2.5, 6), {2.5, 2.5});
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<double> ticks = roundTicks(nan, 1.0, 6);
  ASSERT_EQ(ticks.size(), 2u);
  EXPECT_TRUE(std::isnan(ticks[0]));
}

}  // namespace
}  // namespace piperun::ui
