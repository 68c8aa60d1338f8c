#pragma once
// How far a surface is from round: its points' offsets from a circle, averaged in 10° sectors
// around the axis. Noise averages out within a sector; a square post's faces and corners, or a box
// edge fitted as an arc, move whole sectors. Shared by placement (fitted cylinders) and the joints
// stage's completions (cylinders placed from a pipe end).

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <utility>
#include <vector>

#include "angles.h"

namespace piperun {

class SectorOffsets {
 public:
  /// A point at `angle` around the axis (radians, in [-π, π]) lying `offset` outside the circle.
  void add(double angle, double offset) {
    const int sector = std::min(kSectors - 1, static_cast<int>((angle + kPi) / (2.0 * kPi) * kSectors));
    sum_[static_cast<std::size_t>(sector)] += offset;
    ++count_[static_cast<std::size_t>(sector)];
    squares_ += offset * offset;
    ++points_;
  }

  /// The RMS over sectors of `minSectorPoints` points or more of the sector's mean offset, less the
  /// part noise explains. With kMinSectorsToTrim such sectors or more, the most deviant one is left
  /// out: a mug's handle or a bracket on one side moves one sector, a square's faces move them all.
  double outOfRoundness(int minSectorPoints) const {
    const double variance = squares_ / static_cast<double>(std::max<std::size_t>(1, points_));
    // (squared mean offset, its expected part from noise) per sector with enough points
    std::vector<std::pair<double, double>> sectors;
    for (std::size_t k = 0; k < kSectors; ++k) {
      if (count_[k] < minSectorPoints) continue;
      const double mean = sum_[k] / count_[k];
      sectors.emplace_back(mean * mean, variance / count_[k]);
    }
    if (sectors.size() >= kMinSectorsToTrim) sectors.erase(std::max_element(sectors.begin(), sectors.end()));
    double systematic = 0.0, expected = 0.0;
    for (const auto& [squared, noise] : sectors) {
      systematic += squared;
      expected += noise;
    }
    return sectors.empty() ? 0.0 : std::sqrt(std::max(0.0, systematic - expected) / static_cast<double>(sectors.size()));
  }

 private:
  static constexpr int kSectors = 36;
  static constexpr std::size_t kMinSectorsToTrim = 8;
  std::array<double, kSectors> sum_{};
  std::array<int, kSectors> count_{};
  double squares_ = 0.0;
  std::size_t points_ = 0;
};

}  // namespace piperun
