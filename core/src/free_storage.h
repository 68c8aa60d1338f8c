#pragma once
// Giving a vector's memory back before its owner goes: `v = {}` assigns an empty list and clear()
// empties it, but both keep the capacity.

#include <vector>

namespace piperun {

template <class T, class Allocator>
void freeStorage(std::vector<T, Allocator>& values) {
  std::vector<T, Allocator>().swap(values);
}

}  // namespace piperun
