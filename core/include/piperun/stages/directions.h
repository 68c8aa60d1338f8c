#pragma once
// Stage 2 — principal directions (paper §4): normals on the Gaussian sphere, cross products of
// random normal pairs, mean-shift on the sphere, segmentation of points by stripe.

#include "piperun/point_cloud.h"
#include "piperun/progress.h"

#include <cstdint>
#include <vector>

namespace piperun {

struct DirectionsParams {
  int samplePairs = 20000;        ///< Random normal pairs drawn per round.
  double pairRadius = 0.25;       ///< Pairs are drawn among points closer than this (m), so most lie on one pipe.
  double minPairAngleDeg = 10.0;  ///< Pairs whose normals are closer than this to parallel are skipped.
  double bandwidthDeg = 3.0;      ///< Gaussian kernel width of the mean-shift on the sphere.
  double mergeAngleDeg = 4.0;     ///< Modes (and refined directions) closer than this are one direction.
  double minSupport = 0.02;       ///< A mode must attract at least this share of the round's drawn pairs,
  double minSignificance = 6.0;   ///< stand this many standard deviations above its surroundings on the sphere, and
                                  ///< its stripe must hold this many more held-out points than the band beside it...
  int minStripePoints = 150;      ///< ...and at least this many of the round's points.
  double stripeAngleDeg = 8.0;    ///< A point is in direction d's stripe when |n·d| < sin(this); at most 30...
  double stripeNoiseSigmas = 3.5; ///< ...widened to this many robust standard deviations of the direction's normal noise.
  double minSpreadRatio = 4.0;    ///< A stripe's normals must spread around the axis this many times more than they
                                  ///< stray from perpendicular (in Σ n nᵀ), else the axis is not determined: a plane
                                  ///< alone fits any axis lying in it.
  int maxRounds = 3;              ///< Repeat on the points in no stripe until a round finds nothing.
};

struct PrincipalDirection {
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  ///< Unit vector, folded to the upper hemisphere.
  double support = 0.0;                              ///< Share of the round's drawn pairs that converged to it.
  int round = 0;                                     ///< Round of the stage in which it was found (0 = first).
  double noiseDeg = 0.0;                             ///< Robust std. deviation of its normals' angle from perpendicular.
  double stripeAngleDeg = 0.0;                       ///< Half-width of its stripe (|n·axis| < sin(this)).
  std::vector<std::uint32_t> stripe;                 ///< Points whose normal is perpendicular to it (input order).
};

struct DirectionsInput {
  const PointCloud& cloud;                   ///< Points with unit normals (sign arbitrary).
  const std::vector<std::uint32_t>& points;  ///< The subset to analyse (a tile's unexplained points).
  std::uint64_t seed = 1;
};

struct DirectionsResult {
  std::vector<PrincipalDirection> directions;  ///< By round, strongest first within a round.
  std::vector<Eigen::Vector3f> samples;        ///< The n_i × n_j samples (upper hemisphere), for the sphere view.
  std::vector<int> sampleDirection;            ///< Index of the direction each sample converged to, -1 for none.

  struct Diagnostics {
    std::size_t inputPoints = 0;
    std::size_t ignoredPoints = 0;      ///< Input points without a usable normal (not finite or zero).
    std::size_t pairsDrawn = 0;         ///< Distinct pairs with a partner in reach, parallel ones included.
    std::size_t unexplainedPoints = 0;  ///< Usable points in no stripe at the end.
    int modes = 0;                      ///< Modes that passed minSupport and the peak test, over all rounds.
    int rounds = 0;
    double seconds = 0.0;
  } diagnostics;
};

/// Finds the pipe axis directions among `input.points`. Deterministic for a given seed, whatever the
/// thread count. Throws std::invalid_argument when the cloud has no normals or a parameter is out of
/// range, std::out_of_range for a point index beyond the cloud, Cancelled when progress is cancelled.
DirectionsResult detectDirections(const DirectionsInput& input, const DirectionsParams& params,
                                  Progress& progress = Progress::none());

}  // namespace piperun
