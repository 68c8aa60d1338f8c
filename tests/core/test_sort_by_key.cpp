#include "sort_by_key.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <utility>
#include <vector>

namespace piperun {
namespace {

using Entry = std::pair<std::uint64_t, std::uint32_t>;

std::uint64_t keyOf(const Entry& entry) { return entry.first; }

/// Entries in index order with keys of `bits` bits, many of them repeated.
std::vector<Entry> randomEntries(std::size_t count, int bits, std::uint32_t seed) {
  std::mt19937_64 random(seed);
  const std::uint64_t mask = bits == 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << bits) - 1;
  std::vector<std::uint64_t> pool(count / 4 + 1);
  for (auto& key : pool) key = random() & mask;
  std::vector<Entry> entries(count);
  for (std::size_t i = 0; i < count; ++i) entries[i] = {pool[random() % pool.size()], static_cast<std::uint32_t>(i)};
  return entries;
}

TEST(SortByKey, GivesTheKeyThenIndexOrderOfAComparisonSort) {
  // More entries than one parallel task takes, and keys needing one to six digit passes.
  for (const int bits : {1, 8, 30, 44, 50, 64}) {
    std::vector<Entry> entries = randomEntries(200000, bits, static_cast<std::uint32_t>(bits));
    std::vector<Entry> expected = entries;
    std::sort(expected.begin(), expected.end());
    stableSortByKey(entries, keyOf);
    EXPECT_EQ(entries, expected) << bits << "-bit keys";
  }
}

TEST(SortByKey, KeepsTheOrderOfEqualKeys) {
  std::vector<Entry> entries = {{5, 9}, {2, 7}, {5, 1}, {0, 8}, {2, 3}};
  stableSortByKey(entries, keyOf);
  EXPECT_EQ(entries, (std::vector<Entry>{{0, 8}, {2, 7}, {2, 3}, {5, 9}, {5, 1}}));
}

TEST(SortByKey, HandlesEmptyAndSingleInputs) {
  std::vector<Entry> none;
  stableSortByKey(none, keyOf);
  EXPECT_TRUE(none.empty());
  EXPECT_EQ(runStarts(none, keyOf), std::vector<std::uint32_t>{0});
  std::vector<Entry> one = {{42, 0}};
  stableSortByKey(one, keyOf);
  EXPECT_EQ(one, (std::vector<Entry>{{42, 0}}));
  EXPECT_EQ(runStarts(one, keyOf), (std::vector<std::uint32_t>{0, 1}));
}

TEST(SortByKey, RunStartsMarkEachNewKey) {
  std::vector<Entry> entries = randomEntries(150000, 12, 7);
  stableSortByKey(entries, keyOf);
  std::vector<std::uint32_t> expected;
  for (std::size_t i = 0; i < entries.size(); ++i) {
    if (i == 0 || entries[i].first != entries[i - 1].first) expected.push_back(static_cast<std::uint32_t>(i));
  }
  expected.push_back(static_cast<std::uint32_t>(entries.size()));
  EXPECT_EQ(runStarts(entries, keyOf), expected);
}

}  // namespace
}  // namespace piperun
