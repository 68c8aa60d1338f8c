#pragma once
// A small portable random generator for the synthetic scenes and the stages: xoshiro256** seeded by SplitMix64.
// The standard distributions are implementation-defined, so the same seed would give different
// scenes with another standard library; these are defined here, bit for bit.

#include <cmath>
#include <cstdint>
#include <initializer_list>

namespace piperun {

/// SplitMix64's finaliser: a bijective mixer, for seeding and for hashing cell keys and indices.
inline std::uint64_t mixBits(std::uint64_t z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

class Rng {
 public:
  /// A generator for `seed` and independent streams (e.g. station and strip numbers).
  explicit Rng(std::uint64_t seed, std::initializer_list<std::uint64_t> streams = {}) {
    std::uint64_t key = mixBits(seed + kGolden);
    for (const std::uint64_t stream : streams) key = mixBits(key ^ mixBits(stream + 2 * kGolden));
    for (std::uint64_t& word : state_) word = mixBits(key += kGolden);
  }

  std::uint64_t next() {
    const std::uint64_t result = rotate(state_[1] * 5, 7) * 9;
    const std::uint64_t shifted = state_[1] << 17;
    state_[2] ^= state_[0];
    state_[3] ^= state_[1];
    state_[1] ^= state_[2];
    state_[0] ^= state_[3];
    state_[2] ^= shifted;
    state_[3] = rotate(state_[3], 45);
    return result;
  }

  /// Uniform in [0, 1).
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  double uniform(double low, double high) { return low + (high - low) * uniform(); }
  /// Uniform integer in [low, high].
  int uniformInt(int low, int high) {
    const auto span = static_cast<std::uint64_t>(high - low) + 1;
    return low + static_cast<int>(next() % span);
  }
  bool chance(double probability) { return uniform() < probability; }

  /// Standard normal (Marsaglia's polar method).
  double normal() {
    if (hasSpare_) {
      hasSpare_ = false;
      return spare_;
    }
    double x, y, s;
    do {
      x = uniform(-1.0, 1.0);
      y = uniform(-1.0, 1.0);
      s = x * x + y * y;
    } while (s >= 1.0 || s == 0.0);
    const double scale = std::sqrt(-2.0 * std::log(s) / s);
    spare_ = y * scale;
    hasSpare_ = true;
    return x * scale;
  }

 private:
  static std::uint64_t rotate(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  static constexpr std::uint64_t kGolden = 0x9e3779b97f4a7c15ULL;

  std::uint64_t state_[4];
  double spare_ = 0.0;
  bool hasSpare_ = false;
};

}  // namespace piperun
