#pragma once
// Grouping entries by a 64-bit key (a cell, a voxel, a tile), the first step of every grid here.
// A parallel stable radix sort: entries made in index order come out in (key, index) order, as a
// comparison sort of (key, index) pairs would give, but in a few linear passes over the digits the
// keys actually use. The order is the same for any thread count (a stable sort's result is unique).

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace piperun {

namespace sort_detail {
/// Entries per parallel task; fixed, so the work split does not depend on the thread count.
constexpr std::size_t kChunk = std::size_t{1} << 16;
constexpr int kMaxDigitBits = 11;  // 2048 buckets: the counts of a task stay in the first-level cache
}  // namespace sort_detail

/// Sorts `entries` by keyOf(entry), keeping entries with equal keys in their order.
template <typename Entry, typename KeyOf>
void stableSortByKey(std::vector<Entry>& entries, KeyOf keyOf) {
  using sort_detail::kChunk;
  const std::size_t n = entries.size();
  if (n < 2) return;
  const std::uint64_t maxKey = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, kChunk), std::uint64_t{0},
      [&](const tbb::blocked_range<std::size_t>& range, std::uint64_t high) {
        for (std::size_t i = range.begin(); i < range.end(); ++i) high = std::max(high, keyOf(entries[i]));
        return high;
      },
      [](std::uint64_t a, std::uint64_t b) { return std::max(a, b); });
  int bits = 0;
  while (bits < 64 && (maxKey >> bits) != 0) ++bits;
  if (bits == 0) return;
  // Passes of equal width, each at most kMaxDigitBits.
  const int passes = (bits + sort_detail::kMaxDigitBits - 1) / sort_detail::kMaxDigitBits;
  const int digitBits = (bits + passes - 1) / passes;
  const std::size_t buckets = std::size_t{1} << digitBits;
  const std::uint64_t mask = buckets - 1;

  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<std::size_t> offsets(chunks * buckets);  // chunk c's bucket b at c · buckets + b
  std::vector<Entry> buffer(n);
  for (int shift = 0; shift < bits; shift += digitBits) {
    const auto digit = [&](const Entry& entry) { return static_cast<std::size_t>((keyOf(entry) >> shift) & mask); };
    tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
      std::size_t* counts = offsets.data() + c * buckets;
      std::fill(counts, counts + buckets, std::size_t{0});
      for (std::size_t i = c * kChunk, last = std::min(n, (c + 1) * kChunk); i < last; ++i) ++counts[digit(entries[i])];
    });
    // Bucket by bucket, chunk by chunk: where each chunk's entries of each digit go.
    std::size_t total = 0;
    for (std::size_t b = 0; b < buckets; ++b) {
      for (std::size_t c = 0; c < chunks; ++c) {
        const std::size_t count = offsets[c * buckets + b];
        offsets[c * buckets + b] = total;
        total += count;
      }
    }
    tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
      std::size_t* next = offsets.data() + c * buckets;
      for (std::size_t i = c * kChunk, last = std::min(n, (c + 1) * kChunk); i < last; ++i) {
        buffer[next[digit(entries[i])]++] = entries[i];
      }
    });
    entries.swap(buffer);
  }
}

/// Starts of the runs of equal keys in entries sorted by key, plus the end.
template <typename Entry, typename KeyOf>
std::vector<std::uint32_t> runStarts(const std::vector<Entry>& sorted, KeyOf keyOf) {
  using sort_detail::kChunk;
  const std::size_t n = sorted.size();
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  const auto startsRun = [&](std::size_t i) { return i == 0 || keyOf(sorted[i]) != keyOf(sorted[i - 1]); };
  std::vector<std::size_t> firstOfChunk(chunks + 1, 0);
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    std::size_t count = 0;
    for (std::size_t i = c * kChunk, last = std::min(n, (c + 1) * kChunk); i < last; ++i) count += startsRun(i);
    firstOfChunk[c + 1] = count;
  });
  for (std::size_t c = 0; c < chunks; ++c) firstOfChunk[c + 1] += firstOfChunk[c];
  std::vector<std::uint32_t> starts(firstOfChunk[chunks] + 1);
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    std::size_t out = firstOfChunk[c];
    for (std::size_t i = c * kChunk, last = std::min(n, (c + 1) * kChunk); i < last; ++i) {
      if (startsRun(i)) starts[out++] = static_cast<std::uint32_t>(i);
    }
  });
  starts.back() = static_cast<std::uint32_t>(n);
  return starts;
}

/// An item (a point, a sample) tagged with the 64-bit key of its cell.
using KeyedItem = std::pair<std::uint64_t, std::uint32_t>;
/// Its key, as a function object (a function pointer would not be inlined into the sort's passes).
inline constexpr struct KeyOfItem {
  std::uint64_t operator()(const KeyedItem& entry) const { return entry.first; }
} keyOfItem;

/// Items grouped by key: group g holds items[begins[g], begins[g + 1]) and has keys[g].
struct KeyGroups {
  std::vector<std::uint32_t> items;
  std::vector<std::uint64_t> keys;    // ascending
  std::vector<std::uint32_t> begins;  // one per group, plus the end
};

/// The groups of (key, item) pairs sorted by key.
inline KeyGroups groupByKey(const std::vector<KeyedItem>& sorted) {
  KeyGroups groups;
  groups.begins = runStarts(sorted, keyOfItem);
  groups.items.resize(sorted.size());
  groups.keys.resize(groups.begins.size() - 1);
  tbb::parallel_for(std::size_t{0}, sorted.size(), [&](std::size_t i) { groups.items[i] = sorted[i].second; });
  tbb::parallel_for(std::size_t{0}, groups.keys.size(),
                    [&](std::size_t g) { groups.keys[g] = sorted[groups.begins[g]].first; });
  return groups;
}

}  // namespace piperun
