// Stage 2 — principal directions (Qiu, Zhou & Neumann 2014, §4).
//
// A pipe's normals all lie on the great circle perpendicular to its axis, so the cross product of
// two of its normals is the axis. We draw random pairs of nearby points (near, so that most pairs
// lie on one pipe), map each to d = n_i × n_j folded to the upper hemisphere (d and −d are one
// axis), and look for the dense spots of these samples on the sphere by mean-shift with a Gaussian
// kernel on the angle. Pairs of nearly parallel normals (planes, two points close on one pipe) give
// a meaningless cross product and are skipped, but still count as drawn: a mode's support is its
// share of all drawn pairs, so the rare noisy pairs on a large plane cannot add up to a direction.
//
// Mean-shift: the samples and their antipodes (so modes near the equator are not cut in half) are
// binned finely and the bins bucketed in a grid of cells as large as the kernel's reach. Every cell
// holding samples starts one run at their mean, and its samples are taken to converge where that
// run converges: a coarse but deterministic basin assignment that costs one run per cell instead of
// one per sample. The kernel is exp((cos θ − 1) / σ²), the Gaussian exp(−θ² / 2σ²) to second
// order, cut at 3σ.
//
// Each strong mode is then refined where its samples were drawn: the axis minimising Σ w (n·d)²
// over the normals there is the eigenvector of the smallest eigenvalue of Σ w n nᵀ, with weights
// that fade out normals far from perpendicular (a robust least-squares fit). It averages thousands
// of normals, where a sample carries the noise of two normals amplified by 1 / sin of their angle,
// so it is far more precise than the mode. The noise of those normals is measured too, and the
// stripe widened to a few times it: noisy normals would otherwise leave tails outside the stripe,
// which later rounds would take for directions of their own.
//
// A direction is kept only when it is real. Random normals (outliers, clutter, what earlier
// rounds leave) make chance peaks on the sphere and the search then picks the best of them, so:
// the round's points are split at random and directions are searched for on one half and tested
// on the other, in the cells where the mode's samples were drawn. The test asks whether the stripe
// holds clearly more of the held-out points than the band beside it (see stripeSignificance). A
// plane alone fits every axis lying in it; such an axis is recognised by the stripe's normals not
// spreading around it, and dropped.
//
// Rounds: points in no stripe are analysed again with fresh samples, so a weak direction masked by
// strong ones appears once their points are gone. Stripes always cover the whole input subset (a
// point may be in several), so a later direction's stripe is not eaten by earlier ones.
//
// Determinism: pairs are drawn in fixed chunks, each from its own random stream seeded by (seed,
// round, chunk); the split hashes (seed, round, point); parallel loops write by index and sums are
// reduced over fixed blocks in order.

#include "piperun/stages/directions.h"

#include "angles.h"
#include "cell_table.h"
#include "random.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>
#include <utility>

namespace piperun {

namespace {

constexpr std::uint64_t kStreamTag = 0xd12ec7;  // Keeps this stage's random streams apart from other stages'.
constexpr int kPairsPerChunk = 1024;
constexpr int kPartnerTries = 8;
constexpr std::uint64_t kNoPair = ~std::uint64_t{0};
constexpr double kKernelReach = 3.0;      // The kernel is cut at this many bandwidths.
constexpr int kMaxShiftIterations = 50;
constexpr double kShiftTolerance = 1e-3;  // Radians: a run has converged when it moves less than this.
constexpr int kMaxSphereGridResolution = 96;
constexpr int kMaxFitIterations = 20;
constexpr double kFitTolerance = 1e-5;         // Radians: the axis fit has settled when it moves less than this.
constexpr std::size_t kMaxFitNormals = 20000;  // Plenty for a precise axis; an even subsample beyond.
constexpr double kFitWidthDeg = 1.5;           // Kernel width of the axis fit: about normal noise.
constexpr int kSectors = 6;                    // Azimuth sectors of the stripe test.
constexpr int kNoiseIterations = 20;           // Expectation-maximisation steps of the normal-noise estimate.
constexpr double kMaxStripeAngleDeg = 30.0;    // The stripe test's band beside the stripe must fit on the sphere.
constexpr std::size_t kBlockSize = 8192;       // Points per block of the fixed-order parallel loops.

/// d and −d are one axis: the representative with z > 0 (ties at z = 0 broken by y, then x).
template <typename Vector>
Vector foldedUp(const Vector& d) {
  const bool flip = d.z() < 0 || (d.z() == 0 && (d.y() < 0 || (d.y() == 0 && d.x() < 0)));
  return flip ? Vector(-d) : d;
}

bool usableNormal(const Eigen::Vector3f& n) { return n.allFinite() && n.squaredNorm() > 0.25f; }

/// Points bucketed by cubic cell (of edge pairRadius): where each point lies, and the drawable ones
/// by cell, to draw a random partner near a point.
class PointGrid {
 public:
  PointGrid(const PointCloud& cloud, const std::vector<std::uint32_t>& points, float cellSize)
      : cloud_(cloud), points_(points), cellSize_(cellSize), cellOfPoint_(points.size()) {
    std::vector<std::uint64_t> keys(points.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), kBlockSize), [&](const auto& range) {
      for (std::size_t k = range.begin(); k != range.end(); ++k) keys[k] = cellKey(cellOf(cloud.positions[points[k]]));
    });
    for (std::size_t k = 0; k < points.size(); ++k) cellOfPoint_[k] = cells_.insert(keys[k]);
  }

  /// Makes the points with `drawable` set (by position) the ones randomPartner() draws from.
  void setDrawable(const std::vector<char>& drawable) {
    // Counting sort by cell; within a cell the points' order is kept.
    starts_.assign(static_cast<std::size_t>(cells_.size()) + 1, 0);
    for (std::size_t k = 0; k < points_.size(); ++k) {
      if (drawable[k]) ++starts_[cellOfPoint_[k] + 1];
    }
    std::partial_sum(starts_.begin(), starts_.end(), starts_.begin());
    members_.resize(starts_.back());
    std::vector<std::uint32_t> fill(starts_.begin(), starts_.end() - 1);
    for (std::size_t k = 0; k < points_.size(); ++k) {
      if (drawable[k]) members_[fill[cellOfPoint_[k]]++] = points_[k];
    }
  }

  std::uint32_t cellCount() const { return cells_.size(); }
  /// The cell of the point at `position` in `points`.
  std::uint32_t cellOf(std::size_t position) const { return cellOfPoint_[position]; }

  /// A random drawable point within the cell size (pairRadius) of the one at `position`, other than
  /// it, from the 2 × 2 × 2 cells nearest to it; -1 after kPartnerTries misses.
  std::int64_t randomPartner(std::size_t position, Rng& rng) const {
    const std::uint32_t i = points_[position];
    const Eigen::Vector3f& p = cloud_.positions[i];
    const Eigen::Vector3f scaled = p / cellSize_;
    const Eigen::Vector3i center = scaled.array().floor().cast<int>();
    // Towards the nearer face on each axis.
    const Eigen::Vector3i side =
        (scaled - center.cast<float>()).array().unaryExpr([](float f) { return f < 0.5f ? -1 : 1; });
    std::array<std::pair<std::uint32_t, std::uint32_t>, 8> ranges;  // (first member, cumulative count)
    std::uint32_t total = 0;
    int count = 0;
    for (int corner = 0; corner < 8; ++corner) {
      const Eigen::Vector3i offset((corner & 1) ? side.x() : 0, (corner & 2) ? side.y() : 0, (corner & 4) ? side.z() : 0);
      const std::int64_t cell = corner == 0 ? std::int64_t{cellOfPoint_[position]} : cells_.find(cellKey(center + offset));
      if (cell < 0 || starts_[cell + 1] == starts_[cell]) continue;
      total += starts_[cell + 1] - starts_[cell];
      ranges[count++] = {starts_[cell], total};
    }
    const float radiusSquared = cellSize_ * cellSize_;
    for (int attempt = 0; attempt < kPartnerTries && total > 0; ++attempt) {
      const auto pick = static_cast<std::uint32_t>(rng.next() % total);
      int r = 0;
      while (pick >= ranges[r].second) ++r;
      const std::uint32_t before = r == 0 ? 0 : ranges[r - 1].second;
      const std::uint32_t j = members_[ranges[r].first + (pick - before)];
      if (j != i && (cloud_.positions[j] - p).squaredNorm() <= radiusSquared) return j;
    }
    return -1;
  }

 private:
  Eigen::Vector3i cellOf(const Eigen::Vector3f& p) const { return (p / cellSize_).array().floor().cast<int>(); }

  const PointCloud& cloud_;
  const std::vector<std::uint32_t>& points_;
  float cellSize_;
  CellTable cells_;
  std::vector<std::uint32_t> cellOfPoint_;  // By position in points_.
  std::vector<std::uint32_t> starts_;       // Cell c holds members_[starts_[c], starts_[c + 1]).
  std::vector<std::uint32_t> members_;      // Drawable point indices ordered by cell.
};

struct RoundSamples {
  std::vector<Eigen::Vector3f> samples;  // Unit, upper hemisphere.
  std::vector<std::uint32_t> cells;      // Grid cell of the first point of each sample's pair.
  std::size_t pairsDrawn = 0;            // Distinct pairs with a partner, parallel ones included.
};

/// Draws the round's pairs: the first point uniform among the drawable positions, the second a
/// random drawable point near it.
RoundSamples drawSamples(const PointCloud& cloud, const PointGrid& grid, const std::vector<std::uint32_t>& points,
                         const std::vector<std::uint32_t>& drawablePositions, const DirectionsParams& params,
                         std::uint64_t seed, int round) {
  RoundSamples result;
  if (drawablePositions.size() < 2 || params.samplePairs <= 0) return result;
  const auto minCross = static_cast<float>(std::sin(radians(params.minPairAngleDeg)));

  const auto pairCount = static_cast<std::size_t>(params.samplePairs);
  std::vector<std::uint64_t> pairs(pairCount, kNoPair);  // (smaller index << 32) | larger index.
  std::vector<std::uint32_t> firsts(pairCount);          // Position of the point drawn first.
  const std::size_t chunks = (pairCount + kPairsPerChunk - 1) / kPairsPerChunk;
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t chunk) {
    Rng rng(seed, {kStreamTag, static_cast<std::uint64_t>(round), chunk});
    const std::size_t end = std::min(pairCount, (chunk + 1) * kPairsPerChunk);
    for (std::size_t k = chunk * kPairsPerChunk; k < end; ++k) {
      const std::uint32_t position = drawablePositions[rng.next() % drawablePositions.size()];
      const std::int64_t partner = grid.randomPartner(position, rng);
      if (partner < 0) continue;
      const auto i = std::uint64_t{points[position]}, j = static_cast<std::uint64_t>(partner);
      pairs[k] = (std::min(i, j) << 32) | std::max(i, j);
      firsts[k] = position;
    }
  });

  // A pair drawn twice would put two identical samples on the sphere: a peak made by chance.
  CellTable seen(pairCount);
  for (std::size_t k = 0; k < pairCount; ++k) {
    const std::uint64_t pair = pairs[k];
    if (pair == kNoPair) continue;
    const std::uint32_t before = seen.size();
    if (seen.insert(pair) < before) continue;
    ++result.pairsDrawn;
    const Eigen::Vector3f d = cloud.normals[pair >> 32].cross(cloud.normals[pair & 0xFFFFFFFFu]);
    const float length = d.norm();
    if (length < minCross) continue;
    result.samples.push_back(foldedUp(Eigen::Vector3f(d / length)));
    result.cells.push_back(grid.cellOf(firsts[k]));
  }
  return result;
}

/// The samples and their antipodes for kernel sums on the sphere. They are binned in cubes of about
/// a third of the bandwidth (each bin's mean stands for its samples, weighted by their count: a
/// dense mode costs its bins, not its thousands of samples), and the bins bucketed in a dense grid
/// over [-1, 1]³ of cells at least as wide as the kernel's reach.
class SphereGrid {
 public:
  SphereGrid(const std::vector<Eigen::Vector3f>& samples, double binSize, double reach)
      : resolution_(std::clamp(static_cast<int>(std::floor(2.0 / reach)), 1, kMaxSphereGridResolution)),
        cellSize_(static_cast<float>(2.0 / resolution_)) {
    CellTable binIds;
    std::vector<Eigen::Vector3f> sums;
    std::vector<float> counts;
    const auto bin = static_cast<float>(binSize);
    for (const Eigen::Vector3f& sample : samples) {
      for (const Eigen::Vector3f& p : {sample, Eigen::Vector3f(-sample)}) {
        const std::uint32_t id = binIds.insert(cellKey((p / bin).array().floor().cast<int>()));
        if (id == sums.size()) {
          sums.push_back(Eigen::Vector3f::Zero());
          counts.push_back(0.0f);
        }
        sums[id] += p;
        counts[id] += 1.0f;
      }
    }
    starts_.assign(cellCount() + 1, 0);
    for (const Eigen::Vector3f& sum : sums) ++starts_[cellOf(sum.normalized()) + 1];
    std::partial_sum(starts_.begin(), starts_.end(), starts_.begin());
    means_.resize(sums.size());
    weights_.resize(sums.size());
    std::vector<std::uint32_t> fill(starts_.begin(), starts_.end() - 1);
    for (std::size_t b = 0; b < sums.size(); ++b) {
      const Eigen::Vector3f mean = sums[b].normalized();
      const std::uint32_t slot = fill[cellOf(mean)]++;
      means_[slot] = mean;
      weights_[slot] = counts[b];
    }
  }

  std::size_t cellCount() const { return static_cast<std::size_t>(resolution_) * resolution_ * resolution_; }
  std::size_t cellOf(const Eigen::Vector3f& x) const {
    const auto axis = [&](float v) {
      return static_cast<std::size_t>(std::clamp(static_cast<int>(std::floor((v + 1.0f) / cellSize_)), 0, resolution_ - 1));
    };
    return (axis(x.z()) * resolution_ + axis(x.y())) * resolution_ + axis(x.x());
  }

  /// Calls visit(mean, weight) for every bin in the 3 × 3 × 3 cells around x.
  template <typename Visit>
  void forNeighbours(const Eigen::Vector3f& x, Visit&& visit) const {
    const std::size_t c = cellOf(x);
    const auto r = static_cast<std::size_t>(resolution_);
    const std::size_t cx = c % r, cy = (c / r) % r, cz = c / (r * r);
    for (std::size_t z = cz == 0 ? 0 : cz - 1; z <= std::min(cz + 1, r - 1); ++z) {
      for (std::size_t y = cy == 0 ? 0 : cy - 1; y <= std::min(cy + 1, r - 1); ++y) {
        const std::size_t row = (z * r + y) * r;
        const std::size_t first = row + (cx == 0 ? 0 : cx - 1), last = row + std::min(cx + 1, r - 1);
        for (std::uint32_t slot = starts_[first]; slot < starts_[last + 1]; ++slot) visit(means_[slot], weights_[slot]);
      }
    }
  }

 private:
  int resolution_;
  float cellSize_;
  std::vector<std::uint32_t> starts_;  // Cell c holds bins [starts_[c], starts_[c + 1]).
  std::vector<Eigen::Vector3f> means_;
  std::vector<float> weights_;
};

struct Modes {
  std::vector<Eigen::Vector3d> axes;      // Upper hemisphere, by support, strongest first.
  std::vector<std::size_t> sampleCounts;  // Samples that converged to each mode.
  std::vector<int> sampleMode;            // Mode of each sample, -1 for none.
};

Modes findModes(const std::vector<Eigen::Vector3f>& samples, const DirectionsParams& params) {
  Modes result;
  result.sampleMode.assign(samples.size(), -1);
  if (samples.empty()) return result;
  const double sigma = radians(params.bandwidthDeg);
  const double reach = kKernelReach * sigma;
  const SphereGrid grid(samples, sigma / 3.0, 2.0 * std::sin(0.5 * reach));
  const auto kappa = static_cast<float>(1.0 / (sigma * sigma));
  const auto cosReach = static_cast<float>(std::cos(reach));

  // Seeds: the mean of the samples (not antipodes) in each grid cell; sampleSeed maps samples to seeds.
  std::vector<Eigen::Vector3f> cellSums(grid.cellCount(), Eigen::Vector3f::Zero());
  for (const Eigen::Vector3f& sample : samples) cellSums[grid.cellOf(sample)] += sample;
  std::vector<int> cellSeed(grid.cellCount(), -1);
  std::vector<Eigen::Vector3f> seeds;
  for (std::size_t c = 0; c < cellSums.size(); ++c) {
    if (cellSums[c] == Eigen::Vector3f::Zero()) continue;
    cellSeed[c] = static_cast<int>(seeds.size());
    seeds.push_back(cellSums[c].normalized());
  }
  std::vector<int> sampleSeed(samples.size());
  for (std::size_t k = 0; k < samples.size(); ++k) sampleSeed[k] = cellSeed[grid.cellOf(samples[k])];

  // One mean-shift run per seed; each writes its own slot.
  std::vector<Eigen::Vector3f> converged(seeds.size());
  std::vector<double> density(seeds.size(), 0.0);
  tbb::parallel_for(std::size_t{0}, seeds.size(), [&](std::size_t s) {
    Eigen::Vector3f x = seeds[s];
    double weightSum = 0.0;
    for (int iteration = 0; iteration < kMaxShiftIterations; ++iteration) {
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      weightSum = 0.0;
      grid.forNeighbours(x, [&](const Eigen::Vector3f& p, float count) {
        const float cosine = p.dot(x);
        if (cosine < cosReach) return;
        const double w = count * std::exp(kappa * (cosine - 1.0f));
        mean += w * p.cast<double>();
        weightSum += w;
      });
      const double length = mean.norm();
      if (!(length > 0.0)) break;
      const Eigen::Vector3f next = (mean / length).cast<float>();
      const float step = (next - x).norm();
      x = next;
      if (step < kShiftTolerance) break;
    }
    converged[s] = foldedUp(x);
    density[s] = weightSum;
  });

  // Merge the converged points, densest first, into modes at least mergeAngle apart.
  std::vector<std::size_t> order(seeds.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return density[a] > density[b]; });
  const double cosMerge = std::cos(radians(params.mergeAngleDeg));
  std::vector<int> seedMode(seeds.size(), -1);
  std::vector<Eigen::Vector3d> axes;
  for (const std::size_t s : order) {
    if (!(density[s] > 0.0)) continue;
    const Eigen::Vector3d x = converged[s].cast<double>().normalized();
    int mode = -1;
    for (std::size_t m = 0; m < axes.size() && mode < 0; ++m) {
      if (std::fabs(axes[m].dot(x)) >= cosMerge) mode = static_cast<int>(m);
    }
    if (mode < 0) {
      mode = static_cast<int>(axes.size());
      axes.push_back(x);
    }
    seedMode[s] = mode;
  }

  std::vector<std::size_t> counts(axes.size(), 0);
  for (const int seed : sampleSeed) {
    if (seed >= 0 && seedMode[seed] >= 0) ++counts[seedMode[seed]];
  }
  std::vector<int> byStrength(axes.size());
  std::iota(byStrength.begin(), byStrength.end(), 0);
  std::stable_sort(byStrength.begin(), byStrength.end(), [&](int a, int b) { return counts[a] > counts[b]; });
  std::vector<int> rank(axes.size());
  for (std::size_t r = 0; r < byStrength.size(); ++r) {
    const int mode = byStrength[r];
    rank[mode] = static_cast<int>(r);
    result.axes.push_back(axes[mode]);
    result.sampleCounts.push_back(counts[mode]);
  }
  for (std::size_t k = 0; k < samples.size(); ++k) {
    const int seed = sampleSeed[k];
    if (seed >= 0 && seedMode[seed] >= 0) result.sampleMode[k] = rank[seedMode[seed]];
  }
  return result;
}

/// How far the kernel density at `axis` stands above its surroundings, in standard deviations.
/// The samples in the ring from the kernel's reach to three times it give the local background
/// density λ (per steradian); spread evenly, such samples would give a kernel density of mean
/// 2πσ²λ and variance πσ²λ (the integrals of the kernel and its square over the sphere). A local
/// background, not the global mean, so that a broad unevenness (the normals left once earlier
/// stripes are removed are uneven) is not taken for a peak.
double peakSignificance(const std::vector<Eigen::Vector3f>& samples, const Eigen::Vector3d& axis, double sigma) {
  const double reach = kKernelReach * sigma;
  const double cosReach = std::cos(reach), cosRing = std::cos(3.0 * reach);
  const double kappa = 1.0 / (sigma * sigma);
  double core = 0.0;
  std::size_t ring = 0;
  for (const Eigen::Vector3f& s : samples) {
    const double cosine = std::fabs(s.cast<double>().dot(axis));  // The nearer of s and its antipode.
    if (cosine >= cosReach) {
      core += std::exp(kappa * (cosine - 1.0));
    } else if (cosine >= cosRing) {
      ++ring;
    }
  }
  // At least one sample's worth of background, so that a lone sample in an empty ring is no peak.
  const double ringArea = 2.0 * kPi * (cosReach - cosRing);
  const double background = std::max<double>(ring, 1.0) / ringArea;
  const double mean = 2.0 * kPi * sigma * sigma * background;
  const double deviation = std::sqrt(kPi * sigma * sigma * background);
  return (core - mean) / deviation;
}

/// Sums f(k) over k in [0, count) in parallel, block by block, adding the block sums in order so
/// that the result does not depend on the thread count.
template <typename T, typename Term>
T orderedSum(std::size_t count, const T& zero, Term&& term) {
  const std::size_t blocks = (count + kBlockSize - 1) / kBlockSize;
  std::vector<T> partial(blocks, zero);
  tbb::parallel_for(std::size_t{0}, blocks, [&](std::size_t block) {
    T sum = zero;
    const std::size_t end = std::min(count, (block + 1) * kBlockSize);
    for (std::size_t k = block * kBlockSize; k < end; ++k) term(k, sum);
    partial[block] = sum;
  });
  T total = zero;
  for (const T& sum : partial) total += sum;
  return total;
}

/// Standard deviation (radians) of the angle between `axis`'s perpendicular and the normals of its
/// surfaces, from the normals within `maxAngle` of perpendicular. Those angles are taken as a
/// Gaussian (the direction's surfaces) plus an even background (clutter, other surfaces crossing
/// the band), fitted by expectation-maximisation, so that clutter does not pass for noise.
double normalNoise(const std::vector<Eigen::Vector3f>& normals, const Eigen::Vector3d& axis, double maxAngle) {
  const Eigen::Vector3f d = axis.cast<float>();
  const auto limit = static_cast<float>(std::sin(maxAngle));
  std::vector<double> angles;
  for (const Eigen::Vector3f& n : normals) {
    const float along = std::fabs(n.dot(d));
    if (along < limit) angles.push_back(std::asin(static_cast<double>(along)));
  }
  if (angles.empty()) return 0.0;
  // Start from the median absolute angle; the background density over [-maxAngle, maxAngle].
  std::vector<double> sorted(angles);
  const auto middle = sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2);
  std::nth_element(sorted.begin(), middle, sorted.end());
  double sigma = std::max(1.4826 * *middle, 1e-4);
  double share = 0.5;
  const double background = 1.0 / (2.0 * maxAngle);
  for (int iteration = 0; iteration < kNoiseIterations; ++iteration) {
    double responsibility = 0.0, squares = 0.0;
    for (const double angle : angles) {
      const double gaussian = share * std::exp(-0.5 * angle * angle / (sigma * sigma)) / (std::sqrt(2.0 * kPi) * sigma);
      const double r = gaussian / (gaussian + (1.0 - share) * background);
      responsibility += r;
      squares += r * angle * angle;
    }
    if (!(responsibility > 0.0)) break;
    share = responsibility / static_cast<double>(angles.size());
    sigma = std::max(std::sqrt(squares / responsibility), 1e-4);
  }
  return sigma;
}

struct AxisFit {
  Eigen::Vector3d axis;
  double noise = 0.0;  // Standard deviation (radians) of its normals' angle from perpendicular.
};

/// Refines a mode into the axis its normals are most nearly perpendicular to: the axis minimising
/// Σ w (n·d)², w Gaussian in n·d of width kFitWidthDeg (twice that in a first step, to find the way
/// from the mode). A robust least-squares fit: normals of other surfaces that cross the band barely
/// pull, such as those of a pipe family a few degrees away or a floor under a slightly sloped
/// pipe. Then the noise of the normals is measured about the fitted axis.
AxisFit fitAxis(const PointCloud& cloud, const std::vector<std::uint32_t>& points, const Eigen::Vector3d& mode,
                double noiseBand) {
  AxisFit fit{mode, 0.0};
  const Eigen::Vector3f start = mode.cast<float>();
  const auto sinBand = static_cast<float>(std::sin(noiseBand));
  std::vector<Eigen::Vector3f> normals;
  for (const std::uint32_t i : points) {
    if (std::fabs(cloud.normals[i].dot(start)) < sinBand) normals.push_back(cloud.normals[i]);
  }
  if (normals.empty()) return fit;
  if (normals.size() > kMaxFitNormals) {
    const std::size_t stride = (normals.size() + kMaxFitNormals - 1) / kMaxFitNormals;
    for (std::size_t k = 0; k * stride < normals.size(); ++k) normals[k] = normals[k * stride];
    normals.resize((normals.size() + stride - 1) / stride);
  }
  // One reweighted step; true when the axis has settled.
  const auto step = [&](double width) {
    const double inverseScale = 1.0 / (2.0 * width * width);
    const Eigen::Matrix3d scatter =
        orderedSum(normals.size(), Eigen::Matrix3d::Zero().eval(), [&](std::size_t k, Eigen::Matrix3d& sum) {
          const Eigen::Vector3d n = normals[k].cast<double>();
          const double along = n.dot(fit.axis);
          sum.noalias() += std::exp(-along * along * inverseScale) * (n * n.transpose());
        });
    const Eigen::Vector3d next = foldedUp(Eigen::Vector3d(
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter).eigenvectors().col(0).normalized()));
    const bool settled = std::fabs(next.dot(fit.axis)) > std::cos(kFitTolerance);
    fit.axis = next;
    return settled;
  };
  const double finalWidth = std::sin(radians(kFitWidthDeg));
  step(2.0 * finalWidth);
  for (int iteration = 0; iteration < kMaxFitIterations; ++iteration) {
    if (step(finalWidth)) break;
  }
  fit.noise = normalNoise(normals, fit.axis, noiseBand);
  return fit;
}

/// A direction's stripe and how well its normals determine the axis.
struct Stripe {
  std::vector<std::uint32_t> positions;  // Positions in `points`, ascending.
  double spreadRatio = 0.0;              // Spread of the normals around the axis over their stray from perpendicular.
};

/// The points whose normals are within the stripe, and how much their normals spread around the axis
/// (the smaller eigenvalue of Σ w n nᵀ in the plane perpendicular to it) against how much they
/// stray from perpendicular (dᵀ Σ w n nᵀ d). The weights w, Gaussian in n·d of the normals' noise,
/// keep the stripe's edge (the noise tails of other surfaces) out of that judgement.
Stripe collectStripe(const PointCloud& cloud, const std::vector<std::uint32_t>& points, const Eigen::Vector3d& axis,
                     double sinStripe, double noise) {
  const Eigen::Vector3f d = axis.cast<float>();
  const double inverseScale = 1.0 / (2.0 * noise * noise);
  const std::size_t blocks = (points.size() + kBlockSize - 1) / kBlockSize;
  std::vector<std::vector<std::uint32_t>> positions(blocks);
  std::vector<Eigen::Matrix3d> scatters(blocks, Eigen::Matrix3d::Zero());
  tbb::parallel_for(std::size_t{0}, blocks, [&](std::size_t block) {
    const std::size_t end = std::min(points.size(), (block + 1) * kBlockSize);
    Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
    for (std::size_t k = block * kBlockSize; k < end; ++k) {
      const Eigen::Vector3f& n = cloud.normals[points[k]];
      const double along = n.dot(d);
      if (!(std::fabs(along) < sinStripe)) continue;
      positions[block].push_back(static_cast<std::uint32_t>(k));
      const Eigen::Vector3d nd = n.cast<double>();
      scatter.noalias() += std::exp(-along * along * inverseScale) * (nd * nd.transpose());
    }
    scatters[block] = scatter;
  });
  Stripe stripe;
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (std::size_t block = 0; block < blocks; ++block) {
    stripe.positions.insert(stripe.positions.end(), positions[block].begin(), positions[block].end());
    scatter += scatters[block];
  }
  if (stripe.positions.empty()) return stripe;
  const double stray = axis.dot(scatter * axis);
  const Eigen::Vector3d u = axis.unitOrthogonal();
  const Eigen::Vector3d v = axis.cross(u);
  Eigen::Matrix2d inPlane;
  inPlane << u.dot(scatter * u), u.dot(scatter * v), v.dot(scatter * u), v.dot(scatter * v);
  const double spread = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(inPlane).eigenvalues()(0);
  stripe.spreadRatio = stray > 0.0 ? spread / stray : std::numeric_limits<double>::infinity();
  return stripe;
}

/// How far a stripe stands above chance among the round's points, in standard deviations.
///
/// Normals of random orientation fall as often within the stripe (|n·d| < s) as in the band beside
/// it (s ≤ |n·d| < 2s): on the sphere, area is uniform in n·d (Archimedes), so moving a normal by
/// ±s in n·d at fixed azimuth maps one band onto the other. A pipe's normals fall within. Two
/// things spoil the even chance and are taken out. Normals in earlier rounds' stripes are gone, so
/// a point counts only when its image in the other band lies outside those stripes too. A plane
/// whose normal lies in the band beside (a floor beside a sloped pipe's stripe) is no chance
/// either: the bands are compared sector by sector of azimuth around the axis, and only the
/// sectors where the stripe holds more are summed, so the plane hides no more than its sector.
double stripeSignificance(const PointCloud& cloud, const std::vector<std::uint32_t>& points, const Eigen::Vector3d& axis,
                          const std::vector<std::pair<Eigen::Vector3f, float>>& earlierStripes, double sinStripe) {
  using Counts = Eigen::Array<double, 2, kSectors>;  // Row 0 within the stripe, row 1 beside it.
  const Eigen::Vector3f d = axis.cast<float>();
  const Eigen::Vector3d u3 = axis.unitOrthogonal();
  const Eigen::Vector3f u = u3.cast<float>(), v = axis.cross(u3).cast<float>();
  const auto s = static_cast<float>(sinStripe);
  const Counts counts = orderedSum(points.size(), Counts::Zero().eval(), [&](std::size_t k, Counts& sum) {
    const Eigen::Vector3f& n = cloud.normals[points[k]];
    const float along = n.dot(d);
    const float distance = std::fabs(along);
    if (distance >= 2.0f * s) return;
    const bool within = distance < s;
    const float imageAlong = within ? along + std::copysign(s, along) : along - std::copysign(s, along);
    const Eigen::Vector3f across = (n - along * d).normalized();
    const Eigen::Vector3f image = std::sqrt(std::max(0.0f, 1.0f - imageAlong * imageAlong)) * across + imageAlong * d;
    for (const auto& [earlierAxis, earlierSin] : earlierStripes) {
      if (std::fabs(image.dot(earlierAxis)) < earlierSin) return;
    }
    // Azimuth modulo π: n and −n are one normal.
    float azimuth = std::atan2(n.dot(v), n.dot(u));
    if (azimuth < 0.0f) azimuth += static_cast<float>(kPi);
    const int sector = std::min(kSectors - 1, static_cast<int>(azimuth / static_cast<float>(kPi) * kSectors));
    sum(within ? 0 : 1, sector) += 1.0;
  });
  double excess = 0.0, variance = 0.0;
  for (int sector = 0; sector < kSectors; ++sector) {
    if (counts(0, sector) <= counts(1, sector)) continue;
    excess += counts(0, sector) - counts(1, sector);
    variance += counts(0, sector) + counts(1, sector);
  }
  return variance > 0.0 ? excess / std::sqrt(variance) : 0.0;
}

void checkParams(const DirectionsParams& p) {
  const auto require = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(std::string("detectDirections: ") + what);
  };
  require(p.samplePairs >= 0, "samplePairs must be at least 0");
  require(p.pairRadius > 0.0, "pairRadius must be positive");
  require(p.minPairAngleDeg >= 0.0 && p.minPairAngleDeg < 90.0, "minPairAngleDeg must lie in [0, 90)");
  require(p.bandwidthDeg > 0.0 && p.bandwidthDeg <= 30.0, "bandwidthDeg must lie in (0, 30]");
  require(p.mergeAngleDeg >= 0.0 && p.mergeAngleDeg < 90.0, "mergeAngleDeg must lie in [0, 90)");
  require(p.minSupport >= 0.0 && p.minSupport <= 1.0, "minSupport must lie in [0, 1]");
  require(p.minSignificance >= 0.0, "minSignificance must be at least 0");
  require(p.minStripePoints >= 0, "minStripePoints must be at least 0");
  require(p.stripeAngleDeg > 0.0 && p.stripeAngleDeg <= kMaxStripeAngleDeg, "stripeAngleDeg must lie in (0, 30]");
  require(p.stripeNoiseSigmas >= 0.0, "stripeNoiseSigmas must be at least 0");
  require(p.minSpreadRatio >= 0.0, "minSpreadRatio must be at least 0");
  require(p.maxRounds >= 0, "maxRounds must be at least 0");
}

}  // namespace

DirectionsResult detectDirections(const DirectionsInput& input, const DirectionsParams& params, Progress& progress) {
  const auto start = std::chrono::steady_clock::now();
  checkParams(params);
  const PointCloud& cloud = input.cloud;
  if (!cloud.hasNormals()) throw std::invalid_argument("detectDirections: the cloud has no normals");

  DirectionsResult result;
  result.diagnostics.inputPoints = input.points.size();
  std::vector<std::uint32_t> usable;
  usable.reserve(input.points.size());
  for (const std::uint32_t i : input.points) {
    if (i >= cloud.size()) {
      throw std::out_of_range("detectDirections: point index " + std::to_string(i) + " is beyond the cloud's " +
                              std::to_string(cloud.size()) + " points");
    }
    if (usableNormal(cloud.normals[i])) usable.push_back(i);
  }
  result.diagnostics.ignoredPoints = input.points.size() - usable.size();

  const double sigma = radians(params.bandwidthDeg);
  const double sinStripe = std::sin(radians(params.stripeAngleDeg));
  const double cosMerge = std::cos(radians(params.mergeAngleDeg));
  // The axis fit and the noise estimate look at normals this far from perpendicular: the stripe and
  // twice as much again, so that the noise of its surfaces is seen whole.
  const double noiseBand = std::min(kPi / 2.0, 3.0 * radians(params.stripeAngleDeg));
  const auto minPoints = std::max<std::size_t>(2, static_cast<std::size_t>(params.minStripePoints));
  PointGrid grid(cloud, usable, static_cast<float>(params.pairRadius));
  std::vector<char> covered(usable.size(), 0);  // By position in `usable`: in some stripe.
  std::size_t uncovered = usable.size();
  for (int round = 0; round < params.maxRounds && uncovered >= minPoints; ++round) {
    const auto reportPhase = [&](double phase) { progress.report("directions", (round + phase) / params.maxRounds); };
    progress.checkCancelled();
    reportPhase(0.0);

    // The points are split at random into a search half (samples, mode, axis fit) and a held-out
    // half that only tests: a test on the points the search maximised over would find a
    // "significant" stripe in any noise. Samples are drawn among the round's points (those in no
    // stripe yet); the fit also uses the search half of earlier stripes, so that a direction close
    // to an earlier one keeps the normals the earlier stripe took, all around its axis.
    std::vector<char> drawable(usable.size());
    std::vector<std::uint32_t> drawablePositions, fitPositions, testPositions;
    const std::uint64_t split = mixBits(input.seed ^ mixBits(kStreamTag + static_cast<std::uint64_t>(round)));
    for (std::size_t k = 0; k < usable.size(); ++k) {
      const bool searched = (mixBits(split ^ usable[k]) & 1) == 0;
      drawable[k] = searched && !covered[k];
      const auto position = static_cast<std::uint32_t>(k);
      if (drawable[k]) drawablePositions.push_back(position);
      if (searched) fitPositions.push_back(position);
      if (!searched && !covered[k]) testPositions.push_back(position);
    }
    grid.setDrawable(drawable);
    const RoundSamples drawn = drawSamples(cloud, grid, usable, drawablePositions, params, input.seed, round);
    result.diagnostics.pairsDrawn += drawn.pairsDrawn;
    result.diagnostics.rounds = round + 1;
    progress.checkCancelled();
    reportPhase(0.3);
    const Modes modes = findModes(drawn.samples, params);
    progress.checkCancelled();
    reportPhase(0.6);

    // A mode's region: the cells its samples were drawn in. It is refined and tested there, on
    // the pipes that made it, not on the clutter of the whole subset.
    const auto pointsInRegion = [&](std::size_t mode, const std::vector<std::uint32_t>& positions) {
      std::vector<char> region(grid.cellCount(), 0);
      for (std::size_t k = 0; k < drawn.samples.size(); ++k) {
        if (modes.sampleMode[k] == static_cast<int>(mode)) region[drawn.cells[k]] = 1;
      }
      std::vector<std::uint32_t> inside;
      for (const std::uint32_t position : positions) {
        if (region[grid.cellOf(position)]) inside.push_back(usable[position]);
      }
      return inside;
    };

    const std::vector<char> coveredBefore = covered;
    std::vector<std::pair<Eigen::Vector3f, float>> earlierStripes;  // Axis and sine of the stripe's half-width.
    for (const PrincipalDirection& direction : result.directions) {
      earlierStripes.emplace_back(direction.axis.cast<float>(), static_cast<float>(std::sin(radians(direction.stripeAngleDeg))));
    }
    const std::size_t firstNew = result.directions.size();
    std::vector<int> modeDirection(modes.axes.size(), -1);
    for (std::size_t m = 0; m < modes.axes.size(); ++m) {
      const double support = static_cast<double>(modes.sampleCounts[m]) / static_cast<double>(drawn.pairsDrawn);
      if (support < params.minSupport) break;
      if (peakSignificance(drawn.samples, modes.axes[m], sigma) < params.minSignificance) continue;
      ++result.diagnostics.modes;
      progress.checkCancelled();
      const AxisFit fit = fitAxis(cloud, pointsInRegion(m, fitPositions), modes.axes[m], noiseBand);
      const Eigen::Vector3d& axis = fit.axis;

      // Modes that refine to an axis already found are that direction. Earlier rounds' directions
      // reach as far as their stripes: a later direction that close would be made of the noise
      // tails just outside an earlier stripe (and a pipe that close has most of its points inside).
      int same = -1;
      for (std::size_t d = 0; d < result.directions.size() && same < 0; ++d) {
        const double cosSame = d < firstNew ? std::cos(radians(result.directions[d].stripeAngleDeg)) : cosMerge;
        if (std::fabs(result.directions[d].axis.dot(axis)) >= cosSame) same = static_cast<int>(d);
      }
      if (same >= 0) {
        modeDirection[m] = same;
        if (static_cast<std::size_t>(same) >= firstNew) result.directions[same].support += support;
        continue;
      }

      // Noisy normals need a wider stripe, or the noise tails left outside it would be found as
      // directions of their own in later rounds (and placement would miss those points).
      const double halfWidth = std::min(radians(kMaxStripeAngleDeg),
                                        std::max(radians(params.stripeAngleDeg), params.stripeNoiseSigmas * fit.noise));
      const double sinWidth = std::sin(halfWidth);
      const Stripe stripe =
          collectStripe(cloud, usable, axis, sinWidth, std::max(fit.noise, radians(kFitWidthDeg)));
      // It must explain enough of the points it was found among (all of them in the first round),
      // be determined by its normals, and stand out among the held-out points. That test keeps the
      // stripe parameter's width: widened by a poor noise estimate, its band beside the stripe
      // would reach far enough to find some other surface's normals piled up on one side.
      const auto roundPoints = static_cast<std::size_t>(std::count_if(
          stripe.positions.begin(), stripe.positions.end(), [&](std::uint32_t k) { return !coveredBefore[k]; }));
      if (roundPoints == 0 || roundPoints < static_cast<std::size_t>(params.minStripePoints) ||
          stripe.spreadRatio < params.minSpreadRatio ||
          stripeSignificance(cloud, pointsInRegion(m, testPositions), axis, earlierStripes, sinStripe) <
              params.minSignificance) {
        continue;
      }
      PrincipalDirection direction;
      direction.axis = axis;
      direction.support = support;
      direction.round = round;
      direction.noiseDeg = degrees(fit.noise);
      direction.stripeAngleDeg = degrees(halfWidth);
      direction.stripe.reserve(stripe.positions.size());
      for (const std::uint32_t k : stripe.positions) {
        direction.stripe.push_back(usable[k]);
        if (!covered[k]) --uncovered;
        covered[k] = 1;
      }
      modeDirection[m] = static_cast<int>(result.directions.size());
      result.directions.push_back(std::move(direction));
    }

    for (std::size_t k = 0; k < drawn.samples.size(); ++k) {
      result.samples.push_back(drawn.samples[k]);
      const int mode = modes.sampleMode[k];
      result.sampleDirection.push_back(mode >= 0 ? modeDirection[mode] : -1);
    }
    if (result.directions.size() == firstNew) break;
  }
  result.diagnostics.unexplainedPoints = uncovered;
  progress.report("directions", 1.0);
  result.diagnostics.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace piperun
