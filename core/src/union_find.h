#pragma once
// Disjoint sets over 0..n-1 with path halving; a union keeps the smaller index as the root, so
// the roots (and anything ordered by them) do not depend on the order of the unions.

#include <algorithm>
#include <cstddef>
#include <numeric>
#include <vector>

namespace piperun {

class UnionFind {
 public:
  explicit UnionFind(std::size_t count) : parent_(count) { std::iota(parent_.begin(), parent_.end(), std::size_t{0}); }

  std::size_t find(std::size_t i) {
    while (parent_[i] != i) i = parent_[i] = parent_[parent_[i]];
    return i;
  }
  void unite(std::size_t a, std::size_t b) {
    a = find(a);
    b = find(b);
    if (a != b) parent_[std::max(a, b)] = std::min(a, b);
  }

 private:
  std::vector<std::size_t> parent_;
};

}  // namespace piperun
