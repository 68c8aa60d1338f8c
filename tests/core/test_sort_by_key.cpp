#include "sort_by_key.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <string>
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

/// groupByKey of the stably sorted (key, item) pairs, the items with kNoKey left out.
KeyGroups groupsBySorting(const std::vector<std::uint64_t>& keys) {
  std::vector<KeyedItem> pairs;
  for (std::size_t i = 0; i < keys.size(); ++i) {
    if (keys[i] != kNoKey) pairs.emplace_back(keys[i], static_cast<std::uint32_t>(i));
  }
  stableSortByKey(pairs, keyOfItem);
  return groupByKey(pairs);
}

void expectSameGroups(const KeyGroups& found, const KeyGroups& expected, const std::string& what) {
  EXPECT_EQ(found.items, expected.items) << what;
  EXPECT_EQ(found.keys, expected.keys) << what;
  EXPECT_EQ(found.begins, expected.begins) << what;
}

TEST(GroupItemsByKey, GivesTheGroupsOfTheSortedPairsWhateverTheSlabSize) {
  for (const int bits : {1, 8, 30, 64}) {
    const std::vector<Entry> entries = randomEntries(200000, bits, static_cast<std::uint32_t>(bits) + 100);
    std::vector<std::uint64_t> keys(entries.size());
    for (std::size_t i = 0; i < keys.size(); ++i) keys[i] = i % 97 == 0 ? kNoKey : entries[i].first;
    const KeyGroups expected = groupsBySorting(keys);
    ASSERT_GT(expected.keys.size(), 1u);
    // One slab, a few, many, and slabs of single slices (a slice may outgrow its slab).
    for (const std::size_t slab : {std::size_t{1} << 22, std::size_t{50000}, std::size_t{3000}, std::size_t{1}}) {
      const KeyGroups found = groupItemsByKey(keys.size(), [&](std::size_t i) { return keys[i]; }, slab);
      expectSameGroups(found, expected, std::to_string(bits) + "-bit keys, slabs of " + std::to_string(slab));
    }
  }
}

TEST(GroupItemsByKey, LeavesOutItemsWithoutAKeyAndHandlesEmptyInputs) {
  const std::vector<std::uint64_t> keys = {7, kNoKey, 0, 7, kNoKey, 3};
  const KeyGroups found = groupItemsByKey(keys.size(), [&](std::size_t i) { return keys[i]; });
  EXPECT_EQ(found.items, (std::vector<std::uint32_t>{2, 5, 0, 3}));
  EXPECT_EQ(found.keys, (std::vector<std::uint64_t>{0, 3, 7}));
  EXPECT_EQ(found.begins, (std::vector<std::uint32_t>{0, 1, 2, 4}));

  for (const std::vector<std::uint64_t>& none : {std::vector<std::uint64_t>{}, std::vector<std::uint64_t>{kNoKey, kNoKey}}) {
    const KeyGroups empty = groupItemsByKey(none.size(), [&](std::size_t i) { return none[i]; });
    EXPECT_TRUE(empty.items.empty());
    EXPECT_TRUE(empty.keys.empty());
    EXPECT_EQ(empty.begins, std::vector<std::uint32_t>{0});
  }
  const KeyGroups zero = groupItemsByKey(3, [](std::size_t) { return std::uint64_t{0}; });
  EXPECT_EQ(zero.items, (std::vector<std::uint32_t>{0, 1, 2}));
  EXPECT_EQ(zero.keys, std::vector<std::uint64_t>{0});
}

}  // namespace
}  // namespace piperun
