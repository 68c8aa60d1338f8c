// Hypotheses between pipes, reconstructed and resolved (see joint_resolution.h).

#include "stages/joint_resolution.h"

#include "angles.h"
#include "points_near.h"
#include "stages/segment_axis.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

namespace piperun::joints {

namespace {

// A cylinder fitted across an elbow's bend (see liesOnArc): its middle within this many radii of
// the arc, its ends within this many, at most this share of the arc's length, and at least this
// far off both pipes' lines (deg).
constexpr double kChordMiddleRadii = 0.5;
constexpr double kChordEndRadii = 2.0;
constexpr double kMaxChordArcShare = 1.5;
constexpr double kMinChordOffLineDeg = 15.0;
// An elbow bounded by the room an elbow chosen before it left (see resolveJoints) must hold at
// least this share of the points its pipes' density gives its torus, or more than the wider bend.
constexpr double kMinBoundedSupport = 0.5;
// An elbow hypothesis with a piece of its arc fitted as a cylinder (see resolveJoints) holds that
// piece's joints back from this share of the confidence that accepts a joint: voted without the
// piece's points, which the piece explains, a thinly seen bend falls short of acceptance (small
// seed 38: 0.49, a 90° bend of 273 mm pipe seen over 23 % of its torus), and the piece would
// take an elbow of 28° with one pipe, the bend's other 62° left to no joint.
constexpr double kMinArcElbowAcceptShare = 0.8;
// A piece between two chosen elbows that leave less than this many of its radii of it straight
// may be one bend split in two (see mergeSplitBends).
constexpr double kMaxSplitBendPieceRadii = 2.0;
// ...and the elbow replacing two such must hold at least this share of its points, or as large a
// share as the weaker of the two.
constexpr double kMinMergedBendSupport = 0.8;

/// A spatial index over the pipes' axes: each pipe (by index) is filed in the cells its axis samples,
/// half a cell apart, fall in.
HashGrid pipeAxisGrid(const std::vector<PipeSegment>& pipes, double cellSize) {
  HashGrid grid(cellSize);
  for (std::size_t p = 0; p < pipes.size(); ++p) {
    const PipeSegment& pipe = pipes[p];
    const double length = (pipe.end - pipe.start).norm();
    const int steps = std::max(1, static_cast<int>(std::ceil(length / (0.5 * cellSize))));
    for (int k = 0; k <= steps; ++k) {
      const Eigen::Vector3d sample = pipe.start + (pipe.end - pipe.start) * (static_cast<double>(k) / steps);
      grid.insert(grid.cellOf(sample), static_cast<std::uint32_t>(p));
    }
  }
  return grid;
}

/// The chosen elbow that took end `key`, or nullptr.
const Hypothesis* chosenElbowAt(const Resolution& resolution, int key) {
  const int h = resolution.takenBy[static_cast<std::size_t>(key)];
  if (h < 0) return nullptr;
  const Hypothesis& joint = resolution.hypotheses[static_cast<std::size_t>(h)];
  return joint.type == JointType::Elbow ? &joint : nullptr;
}

/// The end of `elbow` other than the one with key `key`.
const PipeEnd& farEnd(const Hypothesis& elbow, int key) { return elbow.a.key() == key ? elbow.b : elbow.a; }

/// Where `elbow` moves end `key` (its tangent point on that end's pipe).
const Eigen::Vector3d& tangentAt(const Hypothesis& elbow, int key) {
  return elbow.a.key() == key ? elbow.newA : elbow.newB;
}

/// Votes for the bend of elbows again with the points of cylinders fitted on their arcs, which the
/// first vote left out as explained (see JointBuilder::reconstruct): such a piece holds the middle
/// of the bend, and the points left vote for a wrong bend or none.
class ArcPieceRevote {
 public:
  ArcPieceRevote(const JointsInput& input, const JointsParams& params, const std::vector<char>& explained)
      : input_(input), params_(params), explained_(explained) {}

  /// `elbow` reconstructed again over `nearby` with the inliers of `pieces` counted as its own (with
  /// only those voting for its bend, when `piecesOnly`); nullopt when that makes it invalid or leaves
  /// a piece off its arc.
  std::optional<Hypothesis> operator()(const Hypothesis& elbow, const std::vector<std::uint32_t>& nearby,
                                       const std::vector<int>& pieces, bool piecesOnly = false) {
    std::vector<char>& voters = piecesOnly ? onlyPieces_ : withoutPieces_;
    if (voters.empty()) voters = piecesOnly ? std::vector<char>(explained_.size(), 1) : explained_;
    const auto setPieces = [&](auto valueOf) {
      for (int piece : pieces) {
        for (std::uint32_t i : input_.pipes[static_cast<std::size_t>(piece)].inliers) voters[i] = valueOf(i);
      }
    };
    setPieces([](std::uint32_t) { return char{0}; });  // the pieces' points vote...
    Hypothesis revoted = elbow;
    revoted.valid = false;
    revoted.supportPoints.clear();
    revoted.axis.clear();
    JointBuilder(input_, params_, voters).reconstruct(revoted, nearby);
    setPieces([&](std::uint32_t i) { return piecesOnly ? char{1} : explained_[i]; });  // ...this time only
    const bool onArc = std::all_of(pieces.begin(), pieces.end(), [&](int piece) {
      return liesOnArc(input_.pipes[static_cast<std::size_t>(piece)], revoted);
    });
    if (!revoted.valid || !onArc) return std::nullopt;
    return revoted;
  }

 private:
  const JointsInput& input_;
  const JointsParams& params_;
  const std::vector<char>& explained_;
  std::vector<char> withoutPieces_;  // `explained`, copied at the first vote
  std::vector<char> onlyPieces_;     // all explained, made at the first vote of pieces only
};

/// One bend fitted as an elbow or two onto a cylinder fitted across its middle (a real pump room's
/// riser: 38° and 53° around a piece left 4.5 cm long; moved 2 mm, one elbow onto a piece whose
/// other end lies in the riser's tube): where the chosen elbows at a piece's ends leave it less than
/// kMaxSplitBendPieceRadii of its radii straight, or one elbow takes an end and the other is free,
/// the elbow hypotheses between the elbows' far ends (between the one elbow's far end and a free end
/// of another pipe) are voted again by the piece's points alone (the bend's, which the first vote
/// left out as explained; the points left around it had voted for a wrong bend, or none). The
/// first that is then confident, holding as large a share of its points as the weaker of the two
/// elbows or most of them (half, for one), has the piece on its arc and leaves its pipes a section
/// long (`movedEnds`: their far ends where the chosen elbows moved them) takes those two ends, and
/// the piece goes as a piece of its arc.
void mergeSplitBends(const std::vector<PipeSegment>& pipes, const JointsParams& params,
                     const std::vector<std::vector<std::uint32_t>>& nearby, ArcPieceRevote& revote,
                     MovedEnds& movedEnds, Resolution& resolution) {
  auto& hypotheses = resolution.hypotheses;
  auto& takenBy = resolution.takenBy;
  std::vector<std::vector<std::size_t>> elbowsAt(takenBy.size());  // By end key: the valid elbows there.
  for (std::size_t h = 0; h < nearby.size(); ++h) {
    if (!hypotheses[h].valid || hypotheses[h].type != JointType::Elbow) continue;
    elbowsAt[static_cast<std::size_t>(hypotheses[h].a.key())].push_back(h);
    elbowsAt[static_cast<std::size_t>(hypotheses[h].b.key())].push_back(h);
  }
  for (int p = 0; p < static_cast<int>(pipes.size()); ++p) {
    const Hypothesis* first = chosenElbowAt(resolution, 2 * p);
    const Hypothesis* second = chosenElbowAt(resolution, 2 * p + 1);
    const PipeSegment& piece = pipes[static_cast<std::size_t>(p)];
    if (first != nullptr && second != nullptr) {
      const double left = (tangentAt(*second, 2 * p + 1) - tangentAt(*first, 2 * p)).dot(unitAxis(piece));
      if (left >= kMaxSplitBendPieceRadii * piece.radius) continue;
    } else if ((first == nullptr) == (second == nullptr) ||
               takenBy[static_cast<std::size_t>(first == nullptr ? 2 * p : 2 * p + 1)] >= 0) {
      continue;  // No elbow, or the other end took another joint.
    }
    const int elbowSide = first != nullptr ? 0 : 1;
    const Hypothesis& elbow = first != nullptr ? *first : *second;
    const int to = farEnd(elbow, 2 * p + elbowSide).key();
    const int from = first != nullptr && second != nullptr ? farEnd(*second, 2 * p + 1).key() : -1;
    // Two elbows: the one must hold its points as well as the weaker did, or most of them (both
    // small tori may hold all theirs). One: it joins an end no joint took, and must hold half its
    // points, as an elbow bounded by the room left does.
    const double minSupport = from >= 0 ? std::min({first->support, second->support, kMinMergedBendSupport})
                                        : kMinBoundedSupport;
    for (std::size_t h : elbowsAt[static_cast<std::size_t>(to)]) {
      const int other = farEnd(hypotheses[h], to).key();
      if (from >= 0 ? other != from : (other / 2 == p || takenBy[static_cast<std::size_t>(other)] >= 0)) continue;
      const auto merged = revote(hypotheses[h], nearby[h], {p}, true);
      if (!merged || merged->confidence < params.acceptConfidence || merged->support < minSupport ||
          !movedEnds.leaveLength(*merged)) {
        continue;
      }
      auto& chosen = resolution.chosen;
      for (int side = 0; side < 2; ++side) {
        const int taking = takenBy[static_cast<std::size_t>(2 * p + side)];
        if (taking >= 0) {
          chosen.erase(std::remove(chosen.begin(), chosen.end(), static_cast<std::size_t>(taking)), chosen.end());
        }
        takenBy[static_cast<std::size_t>(2 * p + side)] = -1;
      }
      chosen.push_back(h);
      takenBy[static_cast<std::size_t>(other)] = takenBy[static_cast<std::size_t>(to)] = static_cast<int>(h);
      resolution.arcPieces[static_cast<std::size_t>(p)] = 1;
      hypotheses[h] = *merged;
      movedEnds.move(hypotheses[h]);
      ++resolution.diagnostics.mergedSplitBends;
      break;
    }
  }
}

}  // namespace

bool liesOnArc(const PipeSegment& pipe, const Hypothesis& elbow) {
  const auto nearArc = [&](const Eigen::Vector3d& point, double within) {
    return std::any_of(elbow.axis.begin(), elbow.axis.end(),
                       [&](const Eigen::Vector3d& sample) { return (sample - point).norm() <= within; });
  };
  if (nearArc(pipe.start, pipe.radius) && nearArc(pipe.end, pipe.radius)) return true;
  // A cylinder fitted across the bend (a noisy bend's points fit one along a tangent or chord of
  // the arc) leaves the arc at one end: its middle lies on the arc, it runs off both pipes' lines
  // (a piece of either pipe runs along one), and it is at most half as long again as the arc.
  double arcLength = 0.0;
  for (std::size_t k = 1; k < elbow.axis.size(); ++k) arcLength += (elbow.axis[k] - elbow.axis[k - 1]).norm();
  const Eigen::Vector3d axis = unitAxis(pipe);
  const double maxCosine = std::cos(radians(kMinChordOffLineDeg));
  return std::fabs(axis.dot(elbow.a.outward)) <= maxCosine && std::fabs(axis.dot(elbow.b.outward)) <= maxCosine &&
         (pipe.end - pipe.start).norm() <= kMaxChordArcShare * arcLength &&
         nearArc(0.5 * (pipe.start + pipe.end), kChordMiddleRadii * pipe.radius) &&
         nearArc(pipe.start, kChordEndRadii * pipe.radius) && nearArc(pipe.end, kChordEndRadii * pipe.radius);
}

Resolution resolveJoints(const JointsInput& input, const JointsParams& params, const std::vector<char>& explained,
                         std::size_t completionsFrom, const PointCells& cells, Progress& progress) {
  const auto& pipes = input.pipes;
  const int pipeCount = static_cast<int>(pipes.size());
  const JointBuilder builder(input, params, explained);
  Resolution resolution;

  double largestRadius = 0.0;
  for (const auto& pipe : pipes) largestRadius = std::max(largestRadius, pipe.radius);
  const HashGrid pipeGrid = pipeAxisGrid(pipes, cells.cellSize());

  // Hypotheses, in a deterministic order (by end, then by partner).
  auto& hypotheses = resolution.hypotheses;
  std::vector<int> near;
  const auto fragment = [&](int p) { return isFragment(pipes[static_cast<std::size_t>(p)], params); };
  for (int p = 0; p < pipeCount; ++p) {
    if (fragment(p)) continue;
    for (int side = 0; side < 2; ++side) {
      const PipeEnd end = endOf(pipes, p, side);
      const double partnerRadius = end.radius / params.minRadiusRatio;
      // (A tee's main may be the thickest pipe of all: see teeAt.)
      const double reach = std::max({builder.searchDistance(partnerRadius), builder.boundaryGapLimit(partnerRadius),
                                     builder.searchDistance(largestRadius)}) +
                           largestRadius;
      near.clear();
      pipeGrid.forEachInCube(end.point, reach, [&](std::uint32_t other) {
        if (static_cast<int>(other) != p && !fragment(static_cast<int>(other))) near.push_back(static_cast<int>(other));
      });
      std::sort(near.begin(), near.end());
      near.erase(std::unique(near.begin(), near.end()), near.end());
      for (int other : near) {
        ++resolution.diagnostics.candidatePairs;
        builder.tryTee(end, other, hypotheses);
        for (int otherSide = 0; otherSide < 2; ++otherSide) {
          if (2 * other + otherSide < end.key()) continue;  // Each end pair once.
          builder.tryEndPair(end, endOf(pipes, other, otherSide), hypotheses);
        }
      }
    }
  }
  progress.checkCancelled();

  std::vector<std::pair<Eigen::Vector3d, double>> spheres;
  for (const auto& hypothesis : hypotheses) spheres.emplace_back(hypothesis.center, hypothesis.reach);
  const auto nearby = pointsInSpheres(cells, spheres, [](std::size_t) { return true; });
  progress.checkCancelled();
  tbb::parallel_for(std::size_t{0}, hypotheses.size(),
                    [&](std::size_t h) { builder.reconstruct(hypotheses[h], nearby[h]); });
  progress.checkCancelled();
  // A completion starts at the shortest elbow's tangent point, so the bend voted with it says
  // nothing of the corner's shape: only the pipes found by the earlier stages are looked at.
  const auto measured = [&](const PipeEnd& end) { return static_cast<std::size_t>(end.pipe) < completionsFrom; };
  for (std::size_t h = 0, count = hypotheses.size(); h < count; ++h) {
    if (!measured(hypotheses[h].a) || !measured(hypotheses[h].b)) continue;
    if (auto tee = builder.teeForBendlessCorner(hypotheses[h], nearby[h])) {
      hypotheses[h].valid = false;
      hypotheses.push_back(std::move(*tee));
    }
  }

  // A pipe of an elbow's radius lying on the arc of an elbow hypothesis between two other pipes,
  // one nearly confident enough to be accepted, may be a piece of that elbow's arc fitted as a
  // cylinder. Its joints wait for that elbow: they take their ends no earlier than it would.
  constexpr double kNoArc = 2.0;  // Above every confidence.
  std::vector<double> arcConfidence(static_cast<std::size_t>(pipeCount), kNoArc);
  const double holdsBackFrom = kMinArcElbowAcceptShare * params.acceptConfidence;
  for (const Hypothesis& elbow : hypotheses) {
    if (!elbow.valid || elbow.type != JointType::Elbow || elbow.confidence < holdsBackFrom) continue;
    pipeGrid.forEachInCube(elbow.center, elbow.reach, [&](std::uint32_t p) {
      const PipeSegment& pipe = pipes[p];
      const double radiusRatio = std::min(pipe.radius, elbow.a.radius) / std::max(pipe.radius, elbow.a.radius);
      if (static_cast<int>(p) != elbow.a.pipe && static_cast<int>(p) != elbow.b.pipe && !fragment(static_cast<int>(p)) &&
          radiusRatio >= params.minRadiusRatio && liesOnArc(pipe, elbow)) {
        arcConfidence[p] = std::min(arcConfidence[p], elbow.confidence);
      }
    });
  }
  const auto onArc = [&](int p) { return arcConfidence[static_cast<std::size_t>(p)] < kNoArc; };
  const auto otherPipe = [](const Hypothesis& joint) {
    return joint.type == JointType::Tee ? joint.mainPipe : joint.b.pipe;
  };
  const auto rank = [&](std::size_t h) {
    const Hypothesis& joint = hypotheses[h];
    const double waitsFor = std::min(arcConfidence[static_cast<std::size_t>(joint.a.pipe)],
                                     arcConfidence[static_cast<std::size_t>(otherPipe(joint))]);
    // (confidence, whether it does not wait): an elbow goes before the joints that wait for it.
    return std::pair{std::min(joint.confidence, waitsFor), joint.confidence < waitsFor};
  };

  // Conflicts: the best-supported hypothesis takes its ends first.
  std::vector<std::size_t> order;
  for (std::size_t h = 0; h < hypotheses.size(); ++h) {
    if (!hypotheses[h].valid) continue;
    ++resolution.diagnostics.hypotheses[static_cast<std::size_t>(hypotheses[h].type)];
    order.push_back(h);
  }
  std::stable_sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) { return rank(x) > rank(y); });
  auto& takenBy = resolution.takenBy;
  takenBy.assign(2 * static_cast<std::size_t>(pipeCount), -1);
  const auto taken = [&](const PipeEnd& end) { return takenBy[static_cast<std::size_t>(end.key())] >= 0; };
  // A tee whose main stops short of the junction carries the main's line on past that end, as far
  // as the junction at least: no joint may turn the end nearer (a riser that bends at an elbow does
  // not run on to a tee above it). By end: how far past it a chosen tee carries its line.
  std::vector<double> carriedPast(takenBy.size(), -std::numeric_limits<double>::infinity());
  const auto turnsAhead = [](const Hypothesis& joint, const PipeEnd& end) {  // where the joint ends its line
    if (joint.type == JointType::Boundary) return std::numeric_limits<double>::infinity();
    return (joint.corner - end.point).dot(end.outward);
  };
  const auto turnedShort = [&](const Hypothesis& joint, const PipeEnd& end) {
    return carriedPast[static_cast<std::size_t>(end.key())] > turnsAhead(joint, end);
  };
  const auto carriedPastTurn = [&](const Hypothesis& tee) {
    if (!tee.mainEnd) return false;
    const int by = takenBy[static_cast<std::size_t>(tee.mainEnd->key())];
    if (by < 0) return false;
    const Hypothesis& joint = hypotheses[static_cast<std::size_t>(by)];
    const PipeEnd& end = joint.a.key() == tee.mainEnd->key() ? joint.a : joint.b;
    return turnsAhead(joint, end) < turnsAhead(tee, *tee.mainEnd);
  };
  MovedEnds movedEnds(pipes);
  // An elbow whose bend would leave a pipe shorter than a section, after an elbow chosen before it
  // trimmed that pipe's far end (a short pipe between two bends), is voted again with its bend
  // bounded by the room left, and takes that bend when its torus holds half its points or more
  // of them than the wider bend did.
  const auto boundToRoomLeft = [&](Hypothesis& elbow, const std::vector<std::uint32_t>& points) {
    const double tangent = movedEnds.maxTangent(elbow);
    if (tangent <= 0.0) return;
    Hypothesis bounded = elbow;
    bounded.supportPoints.clear();
    bounded.valid = false;
    bounded.maxBendRadius = tangent * std::tan(0.5 * (kPi - bounded.bendAngle));
    builder.reconstruct(bounded, points);
    if (bounded.valid && (bounded.support >= kMinBoundedSupport || bounded.support > elbow.support) &&
        movedEnds.leaveLength(bounded)) {
      elbow = std::move(bounded);
    }
  };
  for (std::size_t h : order) {
    if (hypotheses[h].type == JointType::Elbow && !taken(hypotheses[h].a) && !taken(hypotheses[h].b) &&
        !movedEnds.leaveLength(hypotheses[h]) && movedEnds.farEndMoved(hypotheses[h])) {
      boundToRoomLeft(hypotheses[h], nearby[h]);
    }
    const Hypothesis& hypothesis = hypotheses[h];
    const bool twoEnds = hypothesis.type != JointType::Tee;
    const bool elbow = hypothesis.type == JointType::Elbow;
    if (taken(hypothesis.a) || (twoEnds && taken(hypothesis.b)) || turnedShort(hypothesis, hypothesis.a) ||
        (twoEnds && turnedShort(hypothesis, hypothesis.b)) || carriedPastTurn(hypothesis) ||
        (elbow && !movedEnds.leaveLength(hypothesis))) {
      ++resolution.diagnostics.conflicts;
      continue;
    }
    takenBy[static_cast<std::size_t>(hypothesis.a.key())] = static_cast<int>(h);
    if (twoEnds) takenBy[static_cast<std::size_t>(hypothesis.b.key())] = static_cast<int>(h);
    if (hypothesis.mainEnd) {
      double& past = carriedPast[static_cast<std::size_t>(hypothesis.mainEnd->key())];
      past = std::max(past, turnsAhead(hypothesis, *hypothesis.mainEnd));
    }
    if (elbow) movedEnds.move(hypothesis);
    resolution.chosen.push_back(h);
  }

  resolution.arcPieces.assign(static_cast<std::size_t>(pipeCount), 0);
  auto& chosen = resolution.chosen;
  ArcPieceRevote revote(input, params, explained);
  mergeSplitBends(pipes, params, nearby, revote, movedEnds, resolution);
  // The pieces on the arc of an elbow chosen between two other pipes go, and their own joints
  // with them. The elbow, voted without their points, is voted again with them and with those of
  // the fragments within its tangent length of the corner (bits of the bend too: the pump room
  // moved 11 mm voted R 0.37 m without its bend's four fragments, 0.18 m with them), or without the
  // fragments when one lies off the new arc; it takes that bend when its torus holds more of the
  // points it should (a torus holding all takes no other).
  std::vector<int> pieces, fragments;
  for (std::size_t h : chosen) {
    const Hypothesis& elbow = hypotheses[h];
    if (elbow.type != JointType::Elbow || onArc(elbow.a.pipe) || onArc(elbow.b.pipe)) continue;
    pieces.clear();
    fragments.clear();
    const double tangent = (elbow.newA - elbow.corner).norm();
    pipeGrid.forEachInCube(elbow.center, elbow.reach, [&](std::uint32_t p) {
      const int pipe = static_cast<int>(p);
      if (pipe == elbow.a.pipe || pipe == elbow.b.pipe) return;
      if (onArc(pipe) && liesOnArc(pipes[p], elbow) && !resolution.arcPieces[p]) {
        resolution.arcPieces[p] = 1;
        pieces.push_back(pipe);
      } else if (fragment(pipe) && (pipes[p].start - elbow.corner).norm() <= tangent + pipes[p].radius &&
                 (pipes[p].end - elbow.corner).norm() <= tangent + pipes[p].radius) {
        fragments.push_back(pipe);
      }
    });
    if ((pieces.empty() && fragments.empty()) || h >= nearby.size()) continue;
    std::sort(pieces.begin(), pieces.end());
    std::sort(fragments.begin(), fragments.end());
    std::vector<int> bendPieces = pieces;
    bendPieces.insert(bendPieces.end(), fragments.begin(), fragments.end());
    auto revoted = revote(elbow, nearby[h], bendPieces);
    if (!revoted && !fragments.empty() && !pieces.empty()) revoted = revote(elbow, nearby[h], pieces);
    if (revoted && revoted->support > elbow.support && movedEnds.leaveLength(*revoted)) {
      hypotheses[h] = *revoted;
      movedEnds.move(hypotheses[h]);
      ++resolution.diagnostics.revotedBends;
    }
  }
  const auto onPiece = [&](std::size_t h) {
    return resolution.arcPieces[static_cast<std::size_t>(hypotheses[h].a.pipe)] ||
           resolution.arcPieces[static_cast<std::size_t>(otherPipe(hypotheses[h]))];
  };
  for (std::size_t h : chosen) {
    if (!onPiece(h)) continue;
    takenBy[static_cast<std::size_t>(hypotheses[h].a.key())] = -1;
    if (hypotheses[h].type != JointType::Tee) takenBy[static_cast<std::size_t>(hypotheses[h].b.key())] = -1;
  }
  chosen.erase(std::remove_if(chosen.begin(), chosen.end(), onPiece), chosen.end());
  return resolution;
}

std::vector<PipeEnd> freeEnds(const std::vector<PipeSegment>& pipes, const JointsParams& params,
                              const Resolution& resolution) {
  std::vector<PipeEnd> ends;
  for (int p = 0; p < static_cast<int>(pipes.size()); ++p) {
    const auto pipe = static_cast<std::size_t>(p);
    if (isFragment(pipes[pipe], params) || resolution.arcPieces[pipe]) continue;
    for (int side = 0; side < 2; ++side) {
      if (resolution.takenBy[static_cast<std::size_t>(2 * p + side)] < 0) ends.push_back(endOf(pipes, p, side));
    }
  }
  return ends;
}

}  // namespace piperun::joints
