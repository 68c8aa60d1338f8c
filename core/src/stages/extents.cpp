// Stage 4 — extents (paper §5.2).
//
// A cylinder from placement is infinite and its inliers may come from several pipes on one line,
// from a pipe with occluded stretches, or from stray points that happen to lie on the surface.
// Along the axis the inliers are cut into sections; a section passes when it holds enough points
// (axis coverage) and its points spread around the axis (cross-section coverage: the angle they
// span, i.e. 360° minus the largest angular gap, which a thin sliver of a neighbouring surface or
// a few stray points do not reach). On the pass mask a 1-D closing bridges short occlusions, and
// longer ones between runs of pipe at least as long as the gap (a rack beam in front of a pipe);
// a run's ends go back over lone stray points (20 % outliers carried a pipe a metre past its
// elbow on them); an opening then removes isolated passing sections; each remaining run is a pipe
// that ends at its extreme inliers, unless the closing made up too much of it: on generated small
// scenes (seeds 1–20) runs where fewer than 70 % of the sections passed were nearly all chance fits
// (0.4 m of true pipe against 7 m of false), those at 70–80 % mostly real (24 m against 2 m).
//
// The cross-section default (ExtentsParams::minArcDeg = 45°) is set for single-station scans; the
// paper's 180° needs stations all round a pipe. On generated small scenes scanned from one station
// (seeds 1–4, 1 cm voxels, 2 mm noise) the 4 cm sections of true pipes, pooled to six points, span
// a median of 109–129° of the placement inliers; 5 % span less than 50–60° and 2 % less than
// 28–45°: a station sees at most half a pipe, points thin out towards grazing incidence and the
// inlier test drops the most grazing ones. With 5 mm noise the 5th percentile is 44–64°. At 45°
// about 97 % of true sections pass and the closing bridges most of the rest, while a sliver of a
// surface grazing the cylinder (a band of 10–30°) and isolated stray points fail.

#include "piperun/stages/extents.h"

#include "angles.h"

#include <Eigen/Geometry>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>

namespace piperun {
namespace {

/// Spans [first, last) of sections in a mask.
struct Run {
  std::size_t first, last;
};

std::vector<Run> runsOf(const std::vector<bool>& mask) {
  std::vector<Run> runs;
  for (std::size_t k = 0; k < mask.size(); ++k) {
    if (!mask[k]) continue;
    if (runs.empty() || runs.back().last != k) runs.push_back({k, k});
    runs.back().last = k + 1;
  }
  return runs;
}

/// Share of the sections in [first, last) that passed, from the running count of passing sections.
double passedShare(const std::vector<std::size_t>& passedBefore, std::size_t first, std::size_t last) {
  return static_cast<double>(passedBefore[last] - passedBefore[first]) / static_cast<double>(last - first);
}

/// The parts of [first, last) (both ends passing) that keep `minConfidence` of passing sections:
/// the whole span if it does, otherwise the parts on either side of its longest gap, recursively.
void confidentParts(const std::vector<bool>& pass, const std::vector<std::size_t>& passedBefore, std::size_t first,
                    std::size_t last, double minConfidence, std::vector<Run>& parts) {
  if (passedShare(passedBefore, first, last) >= minConfidence) {
    parts.push_back({first, last});
    return;
  }
  std::size_t gapFirst = first, gapLast = first;
  for (std::size_t k = first; k < last;) {
    if (pass[k]) {
      ++k;
      continue;
    }
    std::size_t end = k;
    while (end < last && !pass[end]) ++end;
    if (end - k > gapLast - gapFirst) gapFirst = k, gapLast = end;
    k = end;
  }
  confidentParts(pass, passedBefore, first, gapFirst, minConfidence, parts);
  confidentParts(pass, passedBefore, gapLast, last, minConfidence, parts);
}

/// 1-D closing (interior gaps of at most `closingSections` are filled; the mask never grows past
/// its outermost passing sections), then gaps of at most `bridgeSections` between runs at least as
/// long as the gap are filled too when the joined run keeps `minConfidence` of passing sections,
/// then an opening (runs shorter than `openingSections` go). A long stretch of pipe on both sides of a gap
/// is strong evidence that the pipe runs on behind whatever hides it; a few scattered passing
/// sections of a chance fit are not. A closed run left with less than `minConfidence` of passing
/// sections is opened again at its longest gaps until its parts keep that share; the part holding
/// the most points (`pointsBefore` counts them) stays when that is more than half the run's and at
/// least `minPartPoints`. A pipe seen whole on one side of a gap and in glimpses between occlusions
/// on the other keeps its whole part; the glimpses of a chance fit through scattered surface
/// patches each hold a small share (every run left keeps the share). A run's ends then go back
/// over lone passing points past a closing length that holds points in too few sections.
std::vector<bool> closeThenOpen(const std::vector<bool>& pass, const std::vector<std::size_t>& pointsBefore,
                                const ExtentsParams& params) {
  const double minConfidence = params.minConfidence;
  std::vector<std::size_t> passedBefore(pass.size() + 1, 0);
  for (std::size_t k = 0; k < pass.size(); ++k) passedBefore[k + 1] = passedBefore[k] + (pass[k] ? 1 : 0);
  std::vector<bool> mask = pass;
  const auto fillGaps = [&](std::size_t maxGap, bool onlyBetweenLongRuns) {
    const std::vector<Run> runs = runsOf(mask);
    for (std::size_t r = 1; r < runs.size(); ++r) {
      const Run& before = runs[r - 1];
      const Run& after = runs[r];
      const std::size_t gap = after.first - before.last;
      if (gap > maxGap) continue;
      if (onlyBetweenLongRuns && (before.last - before.first < gap || after.last - after.first < gap ||
                                  passedShare(passedBefore, before.first, after.last) < minConfidence)) {
        continue;
      }
      std::fill(mask.begin() + before.last, mask.begin() + after.first, true);
    }
  };
  fillGaps(static_cast<std::size_t>(std::max(0, params.closingSections)), false);
  fillGaps(static_cast<std::size_t>(std::max(0, params.bridgeSections)), true);
  const auto pointsIn = [&](const Run& run) { return pointsBefore[run.last] - pointsBefore[run.first]; };
  std::vector<Run> parts;
  for (const Run& run : runsOf(mask)) {
    if (passedShare(passedBefore, run.first, run.last) >= minConfidence) continue;
    std::fill(mask.begin() + run.first, mask.begin() + run.last, false);
    parts.clear();
    confidentParts(pass, passedBefore, run.first, run.last, minConfidence, parts);
    const Run& best = *std::max_element(parts.begin(), parts.end(),
                                        [&](const Run& a, const Run& b) { return pointsIn(a) < pointsIn(b); });
    if (2 * pointsIn(best) > pointsIn(run) && pointsIn(best) >= static_cast<std::size_t>(std::max(0, params.minPartPoints))) {
      std::fill(mask.begin() + best.first, mask.begin() + best.last, true);
    }
  }
  // A run's end must not stand on lone points past a last closing length that holds hardly any:
  // a pipe seen up to its end has points in most of its sections there (passing or not, when
  // sparse), where a few stray points on its line beyond the end, joined on by the closing, do not.
  // (Going back while under min_confidence of the sections hold points cut sparse pipes short.)
  constexpr std::size_t kMaxStrayPoints = 1;  // A section of lone points holds at most this many...
  constexpr double kMaxStrayShare = 0.35;     // ...and its last closing length points in under this share.
  const auto window = static_cast<std::size_t>(std::max(1, params.closingSections));
  std::vector<std::size_t> occupiedBefore(pass.size() + 1, 0);
  for (std::size_t k = 0; k < pass.size(); ++k) {
    occupiedBefore[k + 1] = occupiedBefore[k] + (pointsBefore[k + 1] > pointsBefore[k] ? 1 : 0);
  }
  const auto sparse = [&](std::size_t first, std::size_t last) {
    return static_cast<double>(occupiedBefore[last] - occupiedBefore[first]) <
           kMaxStrayShare * static_cast<double>(last - first);
  };
  const auto stray = [&](std::size_t k) { return pointsBefore[k + 1] - pointsBefore[k] <= kMaxStrayPoints; };
  for (const Run& run : runsOf(mask)) {
    std::size_t first = run.first;
    std::size_t last = run.last;
    while (last - first > window && sparse(last - window, last) && stray(last - 1)) {
      do --last;
      while (!pass[last - 1]);
    }
    while (last - first > window && sparse(first, first + window) && stray(first)) {
      do ++first;
      while (!pass[first]);
    }
    std::fill(mask.begin() + run.first, mask.begin() + first, false);
    std::fill(mask.begin() + last, mask.begin() + run.last, false);
  }
  for (const Run& run : runsOf(mask)) {
    if (run.last - run.first < static_cast<std::size_t>(std::max(0, params.openingSections))) {
      std::fill(mask.begin() + run.first, mask.begin() + run.last, false);
    }
  }
  return mask;
}

/// The angle (degrees) spanned by sorted angles (radians) on the circle: 360° minus the largest gap.
double spannedDeg(const std::vector<double>& sortedAngles) {
  if (sortedAngles.size() < 2) return 0.0;
  double largestGap = sortedAngles.front() + 2.0 * kPi - sortedAngles.back();
  for (std::size_t k = 1; k < sortedAngles.size(); ++k) largestGap = std::max(largestGap, sortedAngles[k] - sortedAngles[k - 1]);
  return 360.0 - degrees(largestGap);
}

std::vector<PipeSegment> segmentsOf(const PointCloud& cloud, const Cylinder& cylinder, int cylinderIndex,
                                    const ExtentsParams& params, std::size_t& sectionCount, std::size_t& keptCount) {
  std::vector<PipeSegment> segments;
  const std::size_t n = cylinder.inliers.size();
  if (n == 0 || !(params.sectionLength > 0.0)) return segments;
  const Eigen::Vector3d axis = cylinder.direction.normalized();
  Eigen::Index smallest = 0;
  axis.cwiseAbs().minCoeff(&smallest);
  const Eigen::Vector3d b1 = axis.cross(Eigen::Vector3d::Unit(smallest)).normalized();
  const Eigen::Vector3d b2 = axis.cross(b1);

  std::vector<double> along(n), angle(n), offset(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d q = cloud.positions[cylinder.inliers[i]].cast<double>() - cylinder.point;
    along[i] = q.dot(axis);
    const Eigen::Vector3d radial = q - along[i] * axis;
    angle[i] = std::atan2(radial.dot(b2), radial.dot(b1));
    offset[i] = radial.norm() - cylinder.radius;
  }
  const auto [lowest, highest] = std::minmax_element(along.begin(), along.end());
  const double start = *lowest;
  const std::size_t sections = static_cast<std::size_t>((*highest - start) / params.sectionLength) + 1;
  const auto sectionOf = [&](std::size_t i) {
    return std::min(sections - 1, static_cast<std::size_t>((along[i] - start) / params.sectionLength));
  };

  // Counting sort of the inliers by section.
  std::vector<std::size_t> begin(sections + 1, 0);
  for (std::size_t i = 0; i < n; ++i) ++begin[sectionOf(i) + 1];
  std::partial_sum(begin.begin(), begin.end(), begin.begin());
  std::vector<std::uint32_t> order(n);
  {
    std::vector<std::size_t> fill(begin.begin(), begin.end() - 1);
    for (std::size_t i = 0; i < n; ++i) order[fill[sectionOf(i)]++] = static_cast<std::uint32_t>(i);
  }

  // Axis coverage threshold of each section, in points. The automatic one follows the density of
  // the pipe around the section: a long pipe thins out with range and grazing incidence, and its
  // far end would fail a threshold set by its dense near part.
  std::vector<double> minPoints(sections, params.minPointsPerMetre * params.sectionLength);
  if (!(params.minPointsPerMetre > 0.0)) {
    std::vector<std::size_t> counts;
    const auto medianCount = [&](std::size_t first, std::size_t last) {
      counts.clear();
      for (std::size_t k = first; k < last; ++k) {
        if (begin[k + 1] > begin[k]) counts.push_back(begin[k + 1] - begin[k]);
      }
      if (counts.empty()) return 0.0;
      std::nth_element(counts.begin(), counts.begin() + counts.size() / 2, counts.end());
      return static_cast<double>(counts[counts.size() / 2]);
    };
    const double whole = medianCount(0, sections);
    const auto reach = static_cast<std::size_t>(std::max(0.0, params.densityWindow / params.sectionLength));
    for (std::size_t k = 0; k < sections; ++k) {
      const double local = medianCount(k - std::min(k, reach), std::min(sections, k + reach + 1));
      minPoints[k] = params.minDensityRatio * std::min(whole, local);
    }
  }

  // Cross-section coverage. Far from the scanner a pipe may leave one or two points per section, so
  // a section is judged together with its neighbours until they hold kMinArcPoints points (reaching
  // at most half the closing length each way); a sliver of another surface stays narrow however
  // many sections it is pooled over.
  constexpr std::size_t kMinArcPoints = 6;
  const std::size_t maxReach = static_cast<std::size_t>(std::max(0, params.closingSections / 2));
  std::vector<bool> pass(sections, false);
  std::vector<double> angles;
  for (std::size_t k = 0; k < sections; ++k) {
    const std::size_t count = begin[k + 1] - begin[k];
    if (count == 0 || static_cast<double>(count) < minPoints[k]) continue;
    std::size_t reach = 0;
    const auto first = [&] { return k - std::min(k, reach); };
    const auto last = [&] { return std::min(sections, k + reach + 1); };
    while (begin[last()] - begin[first()] < kMinArcPoints && reach < maxReach) ++reach;
    angles.clear();
    for (std::size_t j = begin[first()]; j < begin[last()]; ++j) angles.push_back(angle[order[j]]);
    std::sort(angles.begin(), angles.end());
    pass[k] = spannedDeg(angles) >= params.minArcDeg;
  }
  const std::vector<bool> mask = closeThenOpen(pass, begin, params);
  sectionCount += sections;
  keptCount += static_cast<std::size_t>(std::count(mask.begin(), mask.end(), true));

  for (const Run& run : runsOf(mask)) {
    PipeSegment segment;
    double low = std::numeric_limits<double>::infinity(), high = -low, sum2 = 0.0;
    for (std::size_t j = begin[run.first]; j < begin[run.last]; ++j) {
      const std::uint32_t i = order[j];
      low = std::min(low, along[i]);
      high = std::max(high, along[i]);
      sum2 += offset[i] * offset[i];
      segment.inliers.push_back(cylinder.inliers[i]);
    }
    if (segment.inliers.empty() || high - low < params.minLength) continue;
    std::sort(segment.inliers.begin(), segment.inliers.end());
    segment.start = cylinder.point + low * axis;
    segment.end = cylinder.point + high * axis;
    segment.radius = cylinder.radius;
    segment.rms = std::sqrt(sum2 / static_cast<double>(segment.inliers.size()));
    const auto passed = std::count(pass.begin() + static_cast<std::ptrdiff_t>(run.first),
                                   pass.begin() + static_cast<std::ptrdiff_t>(run.last), true);
    segment.confidence = static_cast<double>(passed) / static_cast<double>(run.last - run.first);  // ≥ minConfidence
    segment.cylinderIndex = cylinderIndex;
    segment.mustJoin = cylinder.mustJoin;
    segments.push_back(std::move(segment));
  }
  return segments;
}

}  // namespace

ExtentsResult computeExtents(const ExtentsInput& input, const ExtentsParams& params, Progress& progress) {
  const auto started = std::chrono::steady_clock::now();
  ExtentsResult result;
  const auto& cylinders = input.placement.cylinders;
  progress.report("extents", 0.0);

  struct PerCylinder {
    std::vector<PipeSegment> segments;
    std::size_t sections = 0, kept = 0;
  };
  std::vector<PerCylinder> found(cylinders.size());
  std::atomic<std::size_t> finished{0};
  tbb::parallel_for(std::size_t{0}, cylinders.size(), [&](std::size_t c) {
    progress.checkCancelled();
    found[c].segments = segmentsOf(input.cloud, cylinders[c], static_cast<int>(c), params, found[c].sections, found[c].kept);
    progress.report("extents", static_cast<double>(++finished) / static_cast<double>(cylinders.size()));
  });
  for (PerCylinder& per : found) {
    result.diagnostics.sections += per.sections;
    result.diagnostics.keptSections += per.kept;
    for (PipeSegment& segment : per.segments) result.segments.push_back(std::move(segment));
  }
  result.diagnostics.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  progress.report("extents", 1.0);
  return result;
}

}  // namespace piperun
