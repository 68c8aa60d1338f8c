#include "piperun/edit/network_diff.h"

#include <unordered_map>

namespace piperun {

bool sameElement(const Pipe& a, const Pipe& b) {
  return a.id == b.id && a.radius == b.radius && a.start == b.start && a.end == b.end && a.fitRms == b.fitRms &&
         a.inlierCount == b.inlierCount && a.confidence == b.confidence && a.status == b.status;
}

bool sameElement(const Joint& a, const Joint& b) {
  return a.id == b.id && a.type == b.type && a.pipeIds == b.pipeIds && a.radius == b.radius && a.axis == b.axis &&
         a.bendRadius == b.bendRadius && a.confidence == b.confidence && a.status == b.status;
}

namespace {

template <class Element>
ElementChanges<Element> diffElements(const std::vector<Element>& before, const std::vector<Element>& after) {
  ElementChanges<Element> changes;
  std::unordered_map<int, std::size_t> beforeIndex, afterIndex;
  for (std::size_t i = 0; i < before.size(); ++i) beforeIndex.emplace(before[i].id, i);
  for (std::size_t i = 0; i < after.size(); ++i) afterIndex.emplace(after[i].id, i);
  for (std::size_t i = 0; i < before.size(); ++i) {
    if (!afterIndex.count(before[i].id)) changes.removed.push_back({i, before[i]});
  }
  for (std::size_t i = 0; i < after.size(); ++i) {
    const auto found = beforeIndex.find(after[i].id);
    if (found == beforeIndex.end()) {
      changes.added.push_back({i, after[i]});
    } else if (!sameElement(before[found->second], after[i])) {
      changes.changed.push_back({before[found->second], after[i]});
    }
  }
  return changes;
}

// Removing in descending index order and inserting in ascending order turns one list into the
// other because the elements both hold keep their relative order.
template <class Element>
void replaceElements(std::vector<Element>& elements, const std::vector<typename ElementChanges<Element>::Placed>& remove,
                     const std::vector<typename ElementChanges<Element>::Placed>& insert) {
  for (auto placed = remove.rbegin(); placed != remove.rend(); ++placed) {
    elements.erase(elements.begin() + static_cast<std::ptrdiff_t>(placed->index));
  }
  for (const auto& placed : insert) elements.insert(elements.begin() + static_cast<std::ptrdiff_t>(placed.index), placed.element);
}

template <class Element>
void changeElements(std::vector<Element>& elements, const ElementChanges<Element>& changes, bool forward) {
  if (forward) {
    replaceElements(elements, changes.removed, changes.added);
  } else {
    replaceElements(elements, changes.added, changes.removed);
  }
  std::unordered_map<int, std::size_t> indexOf;
  for (std::size_t i = 0; i < elements.size(); ++i) indexOf.emplace(elements[i].id, i);
  for (const auto& change : changes.changed) {
    const Element& target = forward ? change.after : change.before;
    elements[indexOf.at(target.id)] = target;
  }
}

}  // namespace

NetworkDiff diffNetworks(const PipeNetwork& before, const PipeNetwork& after) {
  return {diffElements(before.pipes, after.pipes), diffElements(before.joints, after.joints)};
}

void applyDiff(PipeNetwork& network, const NetworkDiff& diff) {
  changeElements(network.pipes, diff.pipes, true);
  changeElements(network.joints, diff.joints, true);
}

void revertDiff(PipeNetwork& network, const NetworkDiff& diff) {
  changeElements(network.pipes, diff.pipes, false);
  changeElements(network.joints, diff.joints, false);
}

}  // namespace piperun
