#pragma once
// Grouping entries by a 64-bit key (a cell, a voxel, a tile), the first step of every grid here.
// A parallel stable radix sort: entries made in index order come out in (key, index) order, as a
// comparison sort of (key, index) pairs would give, but in a few linear passes over the digits the
// keys actually use. The order is the same for any thread count (a stable sort's result is unique).

#include "free_storage.h"

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

/// The key of an item with no cell (a non-finite point, a point without a normal): grouping leaves
/// it out.
inline constexpr std::uint64_t kNoKey = ~std::uint64_t{0};

namespace sort_detail {
/// groupItemsByKey sorts about this many (key, item) pairs at a time by default (16 bytes each, and
/// as many again for the sort's buffer)...
constexpr std::size_t kSlabItems = std::size_t{1} << 22;
/// ...in slabs made of slices of the key range: keyOf >> shift for this many bits at most.
constexpr int kSliceBits = 12;
}  // namespace sort_detail

namespace sort_detail {
/// groupItemsByKey for up to a slab's items: every pair made at once, each key computed once.
template <typename KeyOf>
KeyGroups groupAllByKey(std::size_t count, KeyOf keyOf) {
  const std::size_t chunks = (count + kChunk - 1) / kChunk;
  std::vector<KeyedItem> all(count);
  std::vector<std::size_t> keyedBefore(chunks + 1, 0);  // chunk c's first place among the keyed pairs
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    std::size_t keyed = 0;
    for (std::size_t i = c * kChunk, last = std::min(count, (c + 1) * kChunk); i < last; ++i) {
      all[i] = {keyOf(i), static_cast<std::uint32_t>(i)};
      keyed += all[i].first != kNoKey;
    }
    keyedBefore[c + 1] = keyed;
  });
  for (std::size_t c = 0; c < chunks; ++c) keyedBefore[c + 1] += keyedBefore[c];
  std::vector<KeyedItem> pairs(keyedBefore[chunks]);
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    std::size_t place = keyedBefore[c];
    for (std::size_t i = c * kChunk, last = std::min(count, (c + 1) * kChunk); i < last; ++i) {
      if (all[i].first != kNoKey) pairs[place++] = all[i];
    }
  });
  freeStorage(all);
  stableSortByKey(pairs, keyOfItem);
  return groupByKey(pairs);
}
}  // namespace sort_detail

/// Items 0 … count − 1 grouped by keyOf(item) in (key, item) order, items whose key is kNoKey left
/// out: the groups of the stably sorted (key, item) pairs, found a slab of the key range at a time so
/// that beside the 4 bytes an item of the result only a slab's pairs are held (every pair of a
/// 100 million point scan and the sort's buffer took 3.2 GB). keyOf is called a few times an item,
/// once when there are no more items than a slab holds (then all are sorted at once).
template <typename KeyOf>
KeyGroups groupItemsByKey(std::size_t count, KeyOf keyOf, std::size_t slabItems = sort_detail::kSlabItems) {
  using sort_detail::kChunk;
  if (count <= slabItems) return sort_detail::groupAllByKey(count, keyOf);
  KeyGroups groups;
  const std::uint64_t noKeys = 0;
  const auto [maxKey, keyed] = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, count, kChunk), std::pair{noKeys, std::size_t{0}},
      [&](const tbb::blocked_range<std::size_t>& range, std::pair<std::uint64_t, std::size_t> found) {
        for (std::size_t i = range.begin(); i < range.end(); ++i) {
          const std::uint64_t key = keyOf(i);
          if (key == kNoKey) continue;
          found.first = std::max(found.first, key);
          ++found.second;
        }
        return found;
      },
      [](auto a, auto b) { return std::pair{std::max(a.first, b.first), a.second + b.second}; });
  if (keyed == 0) {
    groups.begins = {0};
    return groups;
  }
  int bits = 0;
  while (bits < 64 && (maxKey >> bits) != 0) ++bits;
  const int shift = std::max(0, bits - sort_detail::kSliceBits);
  const std::size_t slices = static_cast<std::size_t>(maxKey >> shift) + 1;

  // Slices joined into slabs of about kSlabItems, in key order.
  const std::size_t chunks = (count + kChunk - 1) / kChunk;
  std::vector<std::uint32_t> perSlice(chunks * slices, 0);  // chunk c's slice s at c · slices + s
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    std::uint32_t* counts = perSlice.data() + c * slices;
    for (std::size_t i = c * kChunk, last = std::min(count, (c + 1) * kChunk); i < last; ++i) {
      const std::uint64_t key = keyOf(i);
      if (key != kNoKey) ++counts[key >> shift];
    }
  });
  std::vector<std::uint32_t> slabOfSlice(slices);
  std::vector<std::size_t> slabBegins = {0};
  std::size_t inSlab = 0;
  for (std::size_t s = 0; s < slices; ++s) {
    std::size_t sliceItems = 0;
    for (std::size_t c = 0; c < chunks; ++c) sliceItems += perSlice[c * slices + s];
    if (inSlab > 0 && inSlab + sliceItems > slabItems) {
      slabBegins.push_back(slabBegins.back() + inSlab);
      inSlab = 0;
    }
    slabOfSlice[s] = static_cast<std::uint32_t>(slabBegins.size() - 1);
    inSlab += sliceItems;
  }
  slabBegins.push_back(keyed);
  const std::size_t slabs = slabBegins.size() - 1;

  // The items by slab, each slab's in item order: chunk by chunk, where each chunk's go.
  std::vector<std::size_t> next(chunks * slabs, 0);
  for (std::size_t c = 0; c < chunks; ++c) {
    for (std::size_t s = 0; s < slices; ++s) next[c * slabs + slabOfSlice[s]] += perSlice[c * slices + s];
  }
  freeStorage(perSlice);
  for (std::size_t b = 0, total = 0; b < slabs; ++b) {
    for (std::size_t c = 0; c < chunks; ++c) {
      const std::size_t items = next[c * slabs + b];
      next[c * slabs + b] = total;
      total += items;
    }
  }
  groups.items.resize(keyed);
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    std::size_t* slot = next.data() + c * slabs;
    for (std::size_t i = c * kChunk, last = std::min(count, (c + 1) * kChunk); i < last; ++i) {
      const std::uint64_t key = keyOf(i);
      if (key != kNoKey) groups.items[slot[slabOfSlice[key >> shift]]++] = static_cast<std::uint32_t>(i);
    }
  });

  // Each slab sorted by (key, item) on its own: its keys all lie below the next slab's.
  std::vector<KeyedItem> pairs;
  for (std::size_t b = 0; b < slabs; ++b) {
    const std::size_t first = slabBegins[b], size = slabBegins[b + 1] - first;
    pairs.resize(size);
    tbb::parallel_for(std::size_t{0}, size, [&](std::size_t j) {
      const std::uint32_t item = groups.items[first + j];
      pairs[j] = {keyOf(item), item};
    });
    stableSortByKey(pairs, keyOfItem);
    tbb::parallel_for(std::size_t{0}, size, [&](std::size_t j) { groups.items[first + j] = pairs[j].second; });
    for (const std::uint32_t start : runStarts(pairs, keyOfItem)) {
      if (start == size) break;
      groups.begins.push_back(static_cast<std::uint32_t>(first + start));
      groups.keys.push_back(pairs[start].first);
    }
  }
  groups.begins.push_back(static_cast<std::uint32_t>(keyed));
  return groups;
}

}  // namespace piperun
