// Merging pipe segments found in overlapping tiles and successive rounds.
//
// Two segments are the same pipe when their axes are nearly parallel, nearly on one line, their
// radii agree, and they overlap or leave only a small gap along the axis. Such pairs are joined
// with union-find (so chains merge transitively) and each group becomes one segment: its axis is
// the length-weighted mean direction through the length-weighted centroid of the members'
// midpoints, its extent the union of the members' projected ends, its radius the inlier-weighted
// mean. Overlap duplicates collapse the same way.
//
// Then an end whose last stretch, a section or longer, holds no inlier of its own, only points on
// the surface of a pipe crossing it, moves back to its own points: the extents bridged onto that
// pipe's flank (retractEndsOnCrossingPipes). And the merged pipes' ends are carried on along their
// axes over the scan (mergeAndExtend). A pipe
// running away from the scanner thins out, and on its far end the normals, estimated over
// neighbourhoods of a few scan columns, stray 30–45° from radial: placement leaves those points out
// of its inliers, and the extents stop where too few remain. Past each end, 4 cm sections holding
// an unexplained point within the pipe's noise band of the surface, with its normal within
// `extensionNormalAngleDeg` of radial, carry the pipe on (gaps of up to three sections, and an
// occlusion of up to `extensionBridgeSections` when the run beyond is as long), until a section
// holds more clutter than surface points (points inside the tube, or unexplained points in a shell
// around it, see isClutter) or the axis would enter another pipe; `maxExtension` at a time, again
// from where an end stopped while it carries the whole way.

#include "piperun/stages/merge.h"

#include "angles.h"
#include "points_near.h"
#include "stages/end_extension.h"
#include "stages/section_runs.h"
#include "stages/segment_axis.h"
#include "union_find.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>

namespace piperun {

namespace {

constexpr double kSection = 0.04;  // Sections along the axis an end is extended by (m), as the extents'.

constexpr double kMinExtendedConfidence = 0.9;  // See extendEnds.

constexpr std::size_t kMaxGap = 3;  // Sections an extension runs on across with no surface point.

double distanceToSegment(const Eigen::Vector3d& p, const PipeSegment& segment) {
  const Eigen::Vector3d axis = unitAxis(segment);
  const double along = std::clamp((p - segment.start).dot(axis), 0.0, (segment.end - segment.start).norm());
  return (p - (segment.start + along * axis)).norm();
}

bool samePipe(const PipeSegment& a, const PipeSegment& b, const MergeParams& params) {
  const Eigen::Vector3d da = unitAxis(a);
  const Eigen::Vector3d db = unitAxis(b);
  if (std::fabs(da.dot(db)) < std::cos(radians(params.maxAngleDeg))) return false;

  if (!radiiAgree(a.radius, b.radius, params.maxRadiusDifference)) return false;

  // The shorter pipe's ends lie on the longer one's axis: measured from the longer one's middle, a
  // degree between the axes would put a short piece near its end off by a centimetre per metre.
  const double axisTolerance = std::max(0.01, params.maxAxisDistance * std::min(a.radius, b.radius));
  const bool aLonger = (a.end - a.start).squaredNorm() >= (b.end - b.start).squaredNorm();
  const PipeSegment& longer = aLonger ? a : b;
  const PipeSegment& shorter = aLonger ? b : a;
  const Eigen::Vector3d longerAxis = aLonger ? da : db;
  if (distanceToLine(shorter.start, longer.start, longerAxis) > axisTolerance ||
      distanceToLine(shorter.end, longer.start, longerAxis) > axisTolerance) {
    return false;
  }

  // Intervals along a's axis.
  double b0 = (b.start - a.start).dot(da);
  double b1 = (b.end - a.start).dot(da);
  if (b0 > b1) std::swap(b0, b1);
  const double a1 = (a.end - a.start).norm();
  const double gap = std::max(0.0, std::max(0.0, b0) - std::min(a1, b1));
  return gap <= params.maxGap;
}

PipeSegment combine(const std::vector<const PipeSegment*>& members) {
  if (members.size() == 1) return *members.front();
  // Orient every member like the longest one before averaging directions.
  const Eigen::Vector3d reference = unitAxis(*members.front());
  Eigen::Vector3d direction = Eigen::Vector3d::Zero();
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  double totalLength = 0.0;
  double weightedRadius = 0.0;
  double weightedSquaredRms = 0.0;
  double weightedConfidence = 0.0;
  double totalInliers = 0.0;
  for (const PipeSegment* member : members) {
    const double length = (member->end - member->start).norm();
    Eigen::Vector3d axis = unitAxis(*member);
    if (axis.dot(reference) < 0.0) axis = -axis;
    direction += length * axis;
    centroid += length * 0.5 * (member->start + member->end);
    totalLength += length;
    weightedConfidence += length * member->confidence;
    const double inliers = std::max<double>(1.0, static_cast<double>(member->inliers.size()));
    weightedRadius += inliers * member->radius;
    weightedSquaredRms += inliers * member->rms * member->rms;
    totalInliers += inliers;
  }
  direction.normalize();
  centroid /= std::max(totalLength, 1e-12);

  double low = std::numeric_limits<double>::infinity();
  double high = -std::numeric_limits<double>::infinity();
  for (const PipeSegment* member : members) {
    for (const Eigen::Vector3d& end : {member->start, member->end}) {
      const double t = (end - centroid).dot(direction);
      low = std::min(low, t);
      high = std::max(high, t);
    }
  }

  PipeSegment merged;
  merged.start = centroid + low * direction;
  merged.end = centroid + high * direction;
  merged.radius = weightedRadius / totalInliers;
  merged.rms = std::sqrt(weightedSquaredRms / totalInliers);
  merged.confidence = weightedConfidence / std::max(totalLength, 1e-12);
  merged.cylinderIndex = members.front()->cylinderIndex;
  // A piece found on firm support elsewhere (another tile, round or stretch) vouches for the pipe.
  merged.mustJoin = std::all_of(members.begin(), members.end(), [](const PipeSegment* member) { return member->mustJoin; });
  for (const PipeSegment* member : members) {
    merged.inliers.insert(merged.inliers.end(), member->inliers.begin(), member->inliers.end());
  }
  std::sort(merged.inliers.begin(), merged.inliers.end());
  merged.inliers.erase(std::unique(merged.inliers.begin(), merged.inliers.end()), merged.inliers.end());
  return merged;
}

// Longest first; ties broken by coordinates so the order never depends on the input order.
bool longerFirst(const PipeSegment& a, const PipeSegment& b) {
  const double la = (a.end - a.start).squaredNorm();
  const double lb = (b.end - b.start).squaredNorm();
  if (la != lb) return la > lb;
  for (int k = 0; k < 3; ++k) {
    if (a.start[k] != b.start[k]) return a.start[k] < b.start[k];
  }
  for (int k = 0; k < 3; ++k) {
    if (a.end[k] != b.end[k]) return a.end[k] < b.end[k];
  }
  return a.radius < b.radius;
}

}  // namespace

/// The band around a pipe's surface its points lie in: three times its RMS offset, at least 6 mm.
double surfaceBand(const PipeSegment& pipe) {
  constexpr double kMinBand = 0.006;
  constexpr double kBandPerRms = 3.0;
  return std::max(kMinBand, kBandPerRms * pipe.rms);
}

/// How far past `end` (along the unit `outward`) the pipe's surface carries on over the points
/// `nearby` (unexplained, near the end), and those points; 0 and none when it does not.
double extension(const PointCloud& cloud, const PipeSegment& pipe, const Eigen::Vector3d& end,
                 const Eigen::Vector3d& outward, double limit, const std::vector<std::uint32_t>& nearby,
                 const std::vector<char>& claimed, const MergeParams& params, std::vector<std::uint32_t>& surface) {
  const double r = pipe.radius;
  const double band = surfaceBand(pipe);
  const double minCos = std::cos(radians(params.extensionNormalAngleDeg));
  const auto sections = static_cast<std::size_t>(std::ceil(params.maxExtension / kSection));
  std::vector<std::vector<std::uint32_t>> bySection(sections);
  std::vector<std::size_t> clutter(sections, 0);
  for (std::uint32_t i : nearby) {
    const Eigen::Vector3d d = cloud.positions[i].cast<double>() - end;
    const double along = d.dot(outward);
    if (along <= 0.0 || along >= params.maxExtension) continue;
    const std::size_t k = std::min(sections - 1, static_cast<std::size_t>(along / kSection));
    const Eigen::Vector3d radial = d - along * outward;
    const double distance = radial.norm();
    if (isClutter(distance, r, band, !claimed[i])) {
      ++clutter[k];
    } else if (!claimed[i] && std::fabs(distance - r) <= band &&
               std::fabs(cloud.normals[i].cast<double>().dot(radial)) >= minCos * distance) {
      bySection[k].push_back(i);
    }
  }
  // Outward over sections holding surface points, across gaps of at most kMaxGap, up to the first
  // section with more clutter than surface points. A longer occlusion is crossed when the run
  // beyond it is at least as long, as the extents bridge.
  std::size_t open = 0;
  while (open < sections && clutter[open] <= bySection[open].size() && static_cast<double>(open + 1) * kSection <= limit) {
    ++open;
  }
  const auto occupied = [&](std::size_t k) { return !bySection[k].empty(); };
  std::size_t first = 0;
  while (first < open && !occupied(first)) ++first;
  if (first >= open || first > kMaxGap) return 0.0;
  const std::size_t last = bridgedEnd(runEnd(first, open, kMaxGap, occupied), open, kMaxGap,
                                      static_cast<std::size_t>(std::max(0, params.extensionBridgeSections)), occupied);
  std::size_t covered = 0;
  for (std::size_t k = 0; k <= last; ++k) covered += bySection[k].empty() ? 0 : 1;
  if (covered < 2) return 0.0;
  double farthest = 0.0;
  for (std::size_t k = 0; k <= last; ++k) {
    for (std::uint32_t i : bySection[k]) {
      farthest = std::max(farthest, (cloud.positions[i].cast<double>() - end).dot(outward));
      surface.push_back(i);
    }
  }
  return farthest;
}

/// How far the axis may run from `end` along `outward` (up to `reach`) before it enters the tube of
/// another of `pipes`: a branch carries on into its main pipe's wall, not through it, and an end
/// stops at the cap of a pipe that carries its line on.
double reachBeforeOtherPipes(const std::vector<PipeSegment>& pipes, std::size_t self, const Eigen::Vector3d& end,
                             const Eigen::Vector3d& outward, double reach) {
  constexpr double kInfinity = std::numeric_limits<double>::infinity();
  for (std::size_t p = 0; p < pipes.size(); ++p) {
    const PipeSegment& other = pipes[p];
    if (p == self || distanceToSegment(end, other) > reach + other.radius) continue;
    // The ray's stretch inside the infinite tube of `other`...
    const Eigen::Vector3d axis = unitAxis(other);
    const Eigen::Vector3d w = end - other.start;
    const Eigen::Vector3d across = outward - outward.dot(axis) * axis;
    const Eigen::Vector3d offset = w - w.dot(axis) * axis;
    const double a = across.squaredNorm(), b = offset.dot(across), c = offset.squaredNorm() - other.radius * other.radius;
    double entry = -kInfinity, exit = kInfinity;
    if (a < 1e-12) {
      if (c >= 0.0) continue;
    } else {
      if (b * b - a * c < 0.0) continue;
      const double root = std::sqrt(b * b - a * c);
      entry = (-b - root) / a;
      exit = (-b + root) / a;
    }
    // ...and between its caps.
    const double along = w.dot(axis), rate = outward.dot(axis), length = (other.end - other.start).norm();
    if (std::fabs(rate) < 1e-12) {
      if (along < 0.0 || along > length) continue;
    } else {
      const double first = -along / rate, second = (length - along) / rate;
      entry = std::max(entry, std::min(first, second));
      exit = std::min(exit, std::max(first, second));
    }
    if (entry < exit && exit > 0.0 && entry < reach) reach = std::max(0.0, entry);
  }
  return reach;
}

namespace {

/// Whether point i lies on the surface of `other`: within its band, between its caps, its normal
/// near radial there.
bool onSurfaceOf(const PointCloud& cloud, std::uint32_t i, const PipeSegment& other) {
  constexpr double kMaxNormalDeg = 30.0;  // As placement's inliers' normals.
  const Eigen::Vector3d axis = unitAxis(other);
  const Eigen::Vector3d w = cloud.positions[i].cast<double>() - other.start;
  const double along = w.dot(axis);
  if (along < 0.0 || along > (other.end - other.start).norm()) return false;
  const Eigen::Vector3d radial = w - along * axis;
  const double distance = radial.norm();
  if (std::fabs(distance - other.radius) > surfaceBand(other) || distance <= 0.0) return false;
  return std::fabs(cloud.normals[i].cast<double>().dot(radial)) >= std::cos(radians(kMaxNormalDeg)) * distance;
}

/// Moves back each end of `pipes` whose last stretch, a section or longer, holds no inlier of its
/// own, only points on the surface of a pipe crossing it, to its last point of its own, and drops
/// those inliers; returns how many ends moved. A pipe passing another's flank takes points there
/// that lie in its band with normals near its radial, and its extents bridge to them: an end carried
/// past an elbow's corner onto a riser beside it meets the riser's body, a tee where the elbow is.
std::size_t retractEndsOnCrossingPipes(const PointCloud& cloud, std::vector<PipeSegment>& pipes) {
  if (!cloud.hasNormals()) return 0;
  constexpr double kMinCrossingDeg = 30.0;  // Pipes closer to parallel are pieces of one line.
  constexpr double kMaxRetraction = 0.5;    // Ends move back this far at most (m), past the gaps the
                                            // extents close (40 cm).
  const double maxCrossingCos = std::cos(radians(kMinCrossingDeg));
  // How far each end moves, judged against the pipes as they were, whatever their order.
  std::vector<std::array<double, 2>> retractions(pipes.size(), {0.0, 0.0});
  std::vector<std::vector<double>> alongs(pipes.size());
  for (std::size_t p = 0; p < pipes.size(); ++p) {
    const PipeSegment& pipe = pipes[p];
    const Eigen::Vector3d axis = unitAxis(pipe);
    const double length = (pipe.end - pipe.start).norm();
    std::vector<double>& along = alongs[p];
    for (std::uint32_t i : pipe.inliers) along.push_back((cloud.positions[i].cast<double>() - pipe.start).dot(axis));
    for (int side = 0; side < 2; ++side) {
      const Eigen::Vector3d end = side == 0 ? pipe.start : pipe.end;
      std::vector<const PipeSegment*> crossing;
      for (std::size_t q = 0; q < pipes.size(); ++q) {
        if (q != p && std::fabs(unitAxis(pipes[q]).dot(axis)) < maxCrossingCos &&
            distanceToSegment(end, pipes[q]) <= pipes[q].radius + kMaxRetraction) {
          crossing.push_back(&pipes[q]);
        }
      }
      if (crossing.empty()) continue;
      // How deep below the end the nearest own and foreign inliers lie.
      double own = length, foreign = length;
      for (std::size_t k = 0; k < along.size(); ++k) {
        const double depth = side == 0 ? along[k] : length - along[k];
        if (depth >= std::min(own, kMaxRetraction)) continue;
        const bool isForeign = std::any_of(crossing.begin(), crossing.end(), [&](const PipeSegment* other) {
          return onSurfaceOf(cloud, pipe.inliers[k], *other);
        });
        double& nearest = isForeign ? foreign : own;
        nearest = std::min(nearest, depth);
      }
      if (own >= kSection && own <= kMaxRetraction && foreign < own) retractions[p][static_cast<std::size_t>(side)] = own;
    }
  }
  std::size_t moved = 0;
  for (std::size_t p = 0; p < pipes.size(); ++p) {
    PipeSegment& pipe = pipes[p];
    const auto [fromStart, fromEnd] = retractions[p];
    const double length = (pipe.end - pipe.start).norm();
    if (fromStart + fromEnd == 0.0 || length - fromStart - fromEnd < kSection) continue;
    std::vector<std::uint32_t> kept;
    for (std::size_t k = 0; k < pipe.inliers.size(); ++k) {
      if (alongs[p][k] >= fromStart && length - alongs[p][k] >= fromEnd) kept.push_back(pipe.inliers[k]);
    }
    pipe.inliers = std::move(kept);
    const Eigen::Vector3d axis = unitAxis(pipe);
    const Eigen::Vector3d start = pipe.start;
    pipe.start = start + fromStart * axis;
    pipe.end = start + (length - fromEnd) * axis;
    moved += (fromStart > 0.0 ? 1 : 0) + (fromEnd > 0.0 ? 1 : 0);
  }
  return moved;
}

/// Extends the ends of `pipes` in place (see mergeAndExtend); returns how many moved. Only pipes
/// whose sections nearly all passed the extents' coverage tests are extended: chance fits along a
/// floor seam or through clutter (0.67–0.87 of their sections on generated scenes) would grow on
/// the same clutter. An end carried the whole `maxExtension` is carried on again from where it
/// stopped, until it stops short: a pipe seen on one flank only over metres (medium seed 11's
/// 168 mm pipe, its last 2.5 m before its elbow seen from below) shows placement no section, and a
/// single reach left the rest of it to a completion's fit of another radius.
std::size_t extendEnds(const PointCloud& cloud, std::vector<PipeSegment>& pipes, const MergeParams& params) {
  if (!(params.maxExtension > 0.0) || pipes.empty() || !cloud.hasNormals()) return 0;
  std::vector<char> claimed(cloud.size(), 0);
  for (const PipeSegment& pipe : pipes) {
    for (std::uint32_t i : pipe.inliers) claimed[i] = 1;
  }
  const std::size_t endCount = 2 * pipes.size();
  const auto outwardOf = [&](std::size_t e) { return Eigen::Vector3d((e % 2 ? 1.0 : -1.0) * unitAxis(pipes[e / 2])); };
  const auto endOf = [&](std::size_t e) -> Eigen::Vector3d& { return e % 2 ? pipes[e / 2].end : pipes[e / 2].start; };
  std::vector<std::size_t> ends;
  for (std::size_t e = 0; e < endCount; ++e) {
    if (pipes[e / 2].confidence >= kMinExtendedConfidence) ends.push_back(e);
  }
  std::vector<char> moved(endCount, 0);
  const double halfLength = 0.5 * params.maxExtension;
  // Each round claims the points it carries ends over, a full reach's worth for every end that goes
  // on, so the rounds end.
  while (!ends.empty()) {
    // The points near each end that may be extended: a sphere around the stretch its extension may
    // cover, out to the shell where extension() counts clutter.
    std::vector<std::pair<Eigen::Vector3d, double>> spheres;
    for (std::size_t e : ends) {
      const PipeSegment& pipe = pipes[e / 2];
      spheres.emplace_back(endOf(e) + halfLength * outwardOf(e),
                           std::hypot(halfLength, 2.0 * (pipe.radius + surfaceBand(pipe))));
    }
    constexpr double kCell = 0.25;
    const auto nearby = pointsInSpheres(cloud, spheres, kCell, [](std::size_t) { return true; });
    std::vector<std::size_t> carriedFully;
    for (std::size_t k = 0; k < ends.size(); ++k) {
      const std::size_t e = ends[k];
      PipeSegment& pipe = pipes[e / 2];
      Eigen::Vector3d& end = endOf(e);
      const Eigen::Vector3d outward = outwardOf(e);
      std::vector<std::uint32_t> surface;
      const double length =
          extension(cloud, pipe, end, outward, reachBeforeOtherPipes(pipes, e / 2, end, outward, params.maxExtension),
                    nearby[k], claimed, params, surface);
      if (!(length > 0.0)) continue;
      end += length * outward;
      for (std::uint32_t i : surface) claimed[i] = 1;
      pipe.inliers.insert(pipe.inliers.end(), surface.begin(), surface.end());
      std::sort(pipe.inliers.begin(), pipe.inliers.end());
      moved[e] = 1;
      // Its surface ran on to within a gap of the reach's end: past it may lie more.
      if (length > params.maxExtension - static_cast<double>(kMaxGap + 1) * kSection) carriedFully.push_back(e);
    }
    ends = std::move(carriedFully);
  }
  return static_cast<std::size_t>(std::count(moved.begin(), moved.end(), 1));
}

}  // namespace

MergeResult mergeAndExtend(const PointCloud& cloud, const std::vector<PipeSegment>& segments, const MergeParams& params,
                           Progress& progress) {
  MergeResult result = mergeSegments(segments, params, progress);
  const auto started = std::chrono::steady_clock::now();
  result.diagnostics.retractedEnds = retractEndsOnCrossingPipes(cloud, result.segments);
  result.diagnostics.extendedEnds = extendEnds(cloud, result.segments, params);
  if (result.diagnostics.extendedEnds > 0) {
    // An end that carried on up to the cap of a pipe on its line now meets it, within the section
    // its extension stopped short by: they are one pipe.
    MergeParams meeting = params;
    meeting.maxGap += kSection;
    Progress quiet(progress, {});
    result.segments = mergeSegments(result.segments, meeting, quiet).segments;
  }
  std::sort(result.segments.begin(), result.segments.end(), longerFirst);
  result.diagnostics.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return result;
}

MergeResult mergeSegments(const std::vector<PipeSegment>& segments, const MergeParams& params, Progress& progress) {
  const auto started = std::chrono::steady_clock::now();
  std::vector<PipeSegment> sorted = segments;
  std::sort(sorted.begin(), sorted.end(), longerFirst);

  UnionFind groups(sorted.size());
  for (std::size_t i = 0; i < sorted.size(); ++i) {
    if (i % 256 == 0) {
      progress.checkCancelled();
      progress.report("merge", static_cast<double>(i) / static_cast<double>(sorted.size()));
    }
    for (std::size_t j = i + 1; j < sorted.size(); ++j) {
      if (samePipe(sorted[i], sorted[j], params)) groups.unite(i, j);
    }
  }

  std::vector<std::vector<const PipeSegment*>> members(sorted.size());
  for (std::size_t i = 0; i < sorted.size(); ++i) members[groups.find(i)].push_back(&sorted[i]);

  MergeResult result;
  for (const auto& group : members) {
    if (!group.empty()) result.segments.push_back(combine(group));
  }
  std::sort(result.segments.begin(), result.segments.end(), longerFirst);
  result.diagnostics.inputSegments = segments.size();
  result.diagnostics.mergedSegments = result.segments.size();
  result.diagnostics.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  progress.report("merge", 1.0);
  return result;
}

}  // namespace piperun
