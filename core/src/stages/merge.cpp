// Merging pipe segments found in overlapping tiles and successive rounds.
//
// Two segments are the same pipe when their axes are nearly parallel, nearly on one line, their
// radii agree, and they overlap or leave only a small gap along the axis. Such pairs are joined
// with union-find (so chains merge transitively) and each group becomes one segment: its axis is
// the length-weighted mean direction through the length-weighted centroid of the members'
// midpoints, its extent the union of the members' projected ends, its radius the inlier-weighted
// mean. Overlap duplicates collapse the same way.

#include "piperun/stages/merge.h"

#include "union_find.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

namespace piperun {

namespace {

constexpr double kPi = 3.14159265358979323846;

Eigen::Vector3d unitAxis(const PipeSegment& segment) {
  const Eigen::Vector3d d = segment.end - segment.start;
  const double length = d.norm();
  return length > 0.0 ? Eigen::Vector3d(d / length) : Eigen::Vector3d::UnitZ();
}

double distanceToLine(const Eigen::Vector3d& p, const Eigen::Vector3d& origin, const Eigen::Vector3d& axis) {
  const Eigen::Vector3d offset = p - origin;
  return (offset - offset.dot(axis) * axis).norm();
}

bool samePipe(const PipeSegment& a, const PipeSegment& b, const MergeParams& params) {
  const Eigen::Vector3d da = unitAxis(a);
  const Eigen::Vector3d db = unitAxis(b);
  if (std::fabs(da.dot(db)) < std::cos(params.maxAngleDeg * kPi / 180.0)) return false;

  const double larger = std::max(a.radius, b.radius);
  if (std::fabs(a.radius - b.radius) > std::max(0.003, params.maxRadiusDifference * larger)) return false;

  const double axisTolerance = std::max(0.01, params.maxAxisDistance * std::min(a.radius, b.radius));
  const Eigen::Vector3d midA = 0.5 * (a.start + a.end);
  const Eigen::Vector3d midB = 0.5 * (b.start + b.end);
  if (distanceToLine(midB, midA, da) > axisTolerance || distanceToLine(midA, midB, db) > axisTolerance) return false;

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
