#pragma once
// Open addressing from 64-bit keys (cell keys, index pairs; never all ones) to dense ids, numbered
// in order of first insertion. Shared by the stages' grids.

#include "random.h"

#include <Eigen/Core>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace piperun {

/// A 63-bit key of the cubic cell with integer coordinates c (each wrapped to 21 bits).
inline std::uint64_t cellKey(const Eigen::Vector3i& c) {
  const auto part = [](int v) { return static_cast<std::uint64_t>(static_cast<std::uint32_t>(v) & 0x1FFFFFu); };
  return part(c.x()) | (part(c.y()) << 21) | (part(c.z()) << 42);
}

class CellTable {
 public:
  /// A table sized for `expected` keys (it grows past them).
  explicit CellTable(std::size_t expected = 0) {
    if (expected == 0) return;
    std::size_t slots = 16;
    while (slots < 2 * (expected + 1)) slots *= 2;
    keys_.assign(slots, kEmpty);
    ids_.resize(slots);
  }

  /// The id of `key` (which must not be all ones), a new one when the key is new.
  std::uint32_t insert(std::uint64_t key) {
    if (2 * (static_cast<std::size_t>(size_) + 1) > keys_.size()) grow();
    const std::size_t slot = probe(key);
    if (keys_[slot] == kEmpty) {
      keys_[slot] = key;
      ids_[slot] = size_++;
    }
    return ids_[slot];
  }
  /// The id of `key`, -1 when it was never inserted.
  std::int64_t find(std::uint64_t key) const {
    if (keys_.empty()) return -1;
    const std::size_t slot = probe(key);
    return keys_[slot] == kEmpty ? std::int64_t{-1} : std::int64_t{ids_[slot]};
  }
  std::uint32_t size() const { return size_; }

 private:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};  // no key is all ones

  std::size_t probe(std::uint64_t key) const {
    const std::size_t mask = keys_.size() - 1;
    std::size_t slot = static_cast<std::size_t>(mixBits(key)) & mask;
    while (keys_[slot] != kEmpty && keys_[slot] != key) slot = (slot + 1) & mask;
    return slot;
  }
  void grow() {
    std::vector<std::uint64_t> keys(std::max<std::size_t>(1024, 2 * keys_.size()), kEmpty);
    std::vector<std::uint32_t> ids(keys.size());
    keys.swap(keys_);
    ids.swap(ids_);
    for (std::size_t k = 0; k < keys.size(); ++k) {
      if (keys[k] == kEmpty) continue;
      const std::size_t slot = probe(keys[k]);
      keys_[slot] = keys[k];
      ids_[slot] = ids[k];
    }
  }

  std::vector<std::uint64_t> keys_;
  std::vector<std::uint32_t> ids_;
  std::uint32_t size_ = 0;
};

}  // namespace piperun
