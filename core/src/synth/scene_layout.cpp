#include "synth/scene_layout.h"

#include <tbb/parallel_for.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

#include "angles.h"
#include "random.h"
#include "segment_distance.h"
#include "synth/scanner.h"

namespace piperun::synth {
namespace {

// Outside radii of NPS pipe sizes 1" to 22" (ASME B36.10 outside diameters / 2), metres.
constexpr std::array<double, 17> kNominalRadii = {0.0167,  0.0211,  0.02415, 0.03015, 0.0365, 0.04445,
                                                  0.05715, 0.07065, 0.08415, 0.10955, 0.1365, 0.1619,
                                                  0.1778,  0.2032,  0.2285,  0.254,   0.2795};
constexpr int kHandrailRadiusIndex = 1;           // 1 1/4" tube, 42.2 mm outside diameter
constexpr double kClearance = 0.015;              // between surfaces of different runs and boxes (m)
constexpr double kMinStraight = 0.1;              // shortest straight pipe between or after elbows (m)
constexpr double kArcStep = 0.01;                 // elbow axis sampling (m)
constexpr double kBuriedLength = 0.02;            // pipe ends continue this far into the surface they enter
constexpr double kMaxEntryTilt = 25.0 * kDegree;  // between a pipe entering a surface and its normal
constexpr double kLongRadiusShare = 0.7;          // long-radius elbows (1.5 D) against short-radius (1 D)
constexpr double kSlab = 0.3;                     // thickness of the floor and roof slabs (m)
constexpr double kWall = 0.25;                    // thickness of the walls (m)
constexpr int kFloor = 0;                         // blocker index of the floor slab, laid first

/// What a preset's scenes are made of; ranges are drawn uniformly per scene.
struct PresetConfig {
  std::array<double, 2> width{}, depth{};  ///< Room footprint along h1 and h2 (m).
  double height = 0.0;                     ///< Room height (m).
  std::array<int, 2> racks{}, rackPipes{};
  std::array<double, 2> rackHeight{};  ///< Top of the rack beams (m).
  std::array<int, 2> pipes{};          ///< Truth pipes to aim for.
  std::array<int, 2> equipment{}, platforms{}, walkways{}, slopedRuns{}, walls{};
  int maxRadiusIndex = 0;                 ///< Largest nominal size used.
  std::array<double, 3> directionOdds{};  ///< Odds of 2, 3 and 4 principal directions.
  double maxLeg = 0.0;                    ///< Longest leg between elbows (m).
  double maxPipeHeight = 0.0;             ///< Highest corner of a run (m).
};

PresetConfig presetConfig(ScenePreset preset) {
  PresetConfig config;
  switch (preset) {
    case ScenePreset::Small:
      config.width = config.depth = {5.5, 6.5};
      config.height = 4.0;
      config.racks = {1, 1};
      config.rackPipes = {2, 4};
      config.rackHeight = {2.3, 2.8};
      config.pipes = {12, 22};
      config.equipment = {2, 4};
      config.platforms = {0, 1};
      config.walkways = {1, 1};
      config.slopedRuns = {1, 1};
      config.walls = {1, 2};
      config.maxRadiusIndex = 11;  // 12" (16.2 cm)
      config.directionOdds = {0.2, 0.3, 0.5};
      config.maxLeg = 2.5;
      config.maxPipeHeight = 3.6;
      return config;
    case ScenePreset::Medium:
      config.width = {14.0, 16.0};
      config.depth = {11.0, 13.0};
      config.height = 6.0;
      config.racks = {2, 2};
      config.rackPipes = {3, 6};
      config.rackHeight = {3.0, 4.2};
      config.pipes = {45, 75};
      config.equipment = {5, 8};
      config.platforms = {1, 2};
      config.walkways = {0, 1};
      config.slopedRuns = {2, 4};
      config.walls = {2, 2};
      config.maxRadiusIndex = 13;  // 16" (20.3 cm)
      config.directionOdds = {0.0, 0.3, 0.7};
      config.maxLeg = 5.0;
      config.maxPipeHeight = 5.4;
      return config;
    case ScenePreset::Large:
      config.width = {38.0, 42.0};
      config.depth = {28.0, 32.0};
      config.height = 10.0;
      config.racks = {4, 5};
      config.rackPipes = {4, 6};
      config.rackHeight = {3.5, 7.0};
      config.pipes = {200, 300};
      config.equipment = {15, 24};
      config.platforms = {3, 5};
      config.walkways = {1, 2};
      config.slopedRuns = {6, 10};
      config.walls = {2, 2};
      config.maxRadiusIndex = 16;  // 22" (27.9 cm)
      config.directionOdds = {0.0, 0.0, 1.0};
      config.maxLeg = 8.0;
      config.maxPipeHeight = 8.5;
      return config;
  }
  throw std::invalid_argument("unknown scene preset");
}

// ---------------------------------------------------------------------------------------------
// Geometry helpers (local scene frame: x = h1, y = h2, z up).

struct Aabb {
  Eigen::Vector3d min = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d max = Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity());

  void extend(const Eigen::Vector3d& p) {
    min = min.cwiseMin(p);
    max = max.cwiseMax(p);
  }
  bool overlaps(const Aabb& other, double margin) const {
    return (min.array() - margin <= other.max.array()).all() && (other.min.array() - margin <= max.array()).all();
  }
};

Aabb boxBounds(const OrientedBox& box) {
  const Eigen::Vector3d reach = box.axes.cwiseAbs() * box.halfExtents;
  Aabb bounds;
  bounds.min = box.center - reach;
  bounds.max = box.center + reach;
  return bounds;
}

Aabb segmentBounds(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double radius) {
  Aabb bounds;
  bounds.min = a.cwiseMin(b).array() - radius;
  bounds.max = a.cwiseMax(b).array() + radius;
  return bounds;
}

OrientedBox alignedBox(const Eigen::Vector3d& min, const Eigen::Vector3d& max) {
  return OrientedBox{0.5 * (min + max), Eigen::Matrix3d::Identity(), 0.5 * (max - min)};
}

double pointBoxDistance(const Eigen::Vector3d& p, const OrientedBox& box) {
  const Eigen::Vector3d local = box.toLocal(p);
  return (local.cwiseAbs() - box.halfExtents).cwiseMax(0.0).norm();
}

/// Distance from a segment to a solid box: the distance to a convex set is convex along the
/// segment, so a golden-section search finds its minimum.
double segmentBoxDistance(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const OrientedBox& box) {
  const double ratio = 0.5 * (std::sqrt(5.0) - 1.0);
  auto at = [&](double t) { return pointBoxDistance(a + t * (b - a), box); };
  double low = 0.0, high = 1.0;
  double x1 = high - ratio * (high - low), x2 = low + ratio * (high - low);
  double f1 = at(x1), f2 = at(x2);
  for (int i = 0; i < 48; ++i) {
    if (f1 <= f2) {
      high = x2;
      x2 = x1;
      f2 = f1;
      x1 = high - ratio * (high - low);
      f1 = at(x1);
    } else {
      low = x1;
      x1 = x2;
      f1 = f2;
      x2 = low + ratio * (high - low);
      f2 = at(x2);
    }
  }
  return std::min({f1, f2, at(0.0), at(1.0)});
}

bool parallel(const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return std::abs(a.dot(b)) > 1.0 - 1e-9; }

// ---------------------------------------------------------------------------------------------
// Routes: centre-line polylines of pipe-runs, turned into pipes and elbows.

struct Route {
  std::vector<Eigen::Vector3d> points;  ///< Corners of the centre line; consecutive legs are not collinear.
  std::vector<double> bendRadii;        ///< Per interior point.
  double radius = 0.0;
  int radiusIndex = 0;
  int teeMain = -1;  ///< Truth pipe the route branches from, or -1.
  Eigen::Vector3d teeAxisPoint = Eigen::Vector3d::Zero();
  int startBlocker = -1;  ///< Box the first / last straight enters (or -1).
  int endBlocker = -1;
  bool startOpen = false;  ///< Cut at the site boundary: capped, visible end.
  bool endOpen = false;
};

struct Bend {
  Eigen::Vector3d center, start, end, u, v;
  double bendRadius = 0.0;
  double sweep = 0.0;
};

/// A route as straight pipes and the elbows between them.
struct RealizedRoute {
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> straights;
  std::vector<Bend> bends;  ///< bends[k] joins straights[k] and straights[k + 1].
};

/// Removes corners where the route goes straight on.
void mergeCollinear(std::vector<Eigen::Vector3d>& points) {
  std::vector<Eigen::Vector3d> kept{points.front()};
  for (std::size_t i = 1; i + 1 < points.size(); ++i) {
    const Eigen::Vector3d in = (points[i] - kept.back()).normalized();
    const Eigen::Vector3d out = (points[i + 1] - points[i]).normalized();
    if (in.dot(out) < 1.0 - 1e-12) kept.push_back(points[i]);
  }
  kept.push_back(points.back());
  points = std::move(kept);
}

/// Elbows at the corners (tangent lengths R tan(φ/2)); nullopt when a straight would be shorter
/// than kMinStraight.
std::optional<RealizedRoute> realize(const Route& route) {
  const auto& p = route.points;
  RealizedRoute realized;
  Eigen::Vector3d straightStart = p.front();
  for (std::size_t k = 1; k + 1 < p.size(); ++k) {
    const Eigen::Vector3d in = (p[k] - p[k - 1]).normalized();
    const Eigen::Vector3d out = (p[k + 1] - p[k]).normalized();
    const double angle = std::acos(std::clamp(in.dot(out), -1.0, 1.0));
    const double R = route.bendRadii[k - 1];
    const double tangent = R * std::tan(0.5 * angle);
    Bend bend;
    bend.bendRadius = R;
    bend.sweep = angle;
    bend.start = p[k] - tangent * in;
    bend.end = p[k] + tangent * out;
    const Eigen::Vector3d inward = (out - out.dot(in) * in).normalized();
    bend.center = bend.start + R * inward;
    bend.u = -inward;
    bend.v = in;
    if ((bend.start - straightStart).dot(in) < kMinStraight) return std::nullopt;
    realized.straights.emplace_back(straightStart, bend.start);
    realized.bends.push_back(bend);
    straightStart = bend.end;
  }
  const Eigen::Vector3d lastDirection = (p.back() - p[p.size() - 2]).normalized();
  if ((p.back() - straightStart).dot(lastDirection) < kMinStraight) return std::nullopt;
  realized.straights.emplace_back(straightStart, p.back());
  return realized;
}

Eigen::Vector3d arcPoint(const Bend& bend, double angle) {
  return bend.center + bend.bendRadius * (std::cos(angle) * bend.u + std::sin(angle) * bend.v);
}

/// A route's solid pieces for clearance tests: straights, and chords of the elbow arcs with the
/// radius grown by the chord's sagitta.
struct Piece {
  Eigen::Vector3d a, b;
  double radius;
  int straight;  ///< Index of the straight, or -1 for elbow chords.
};

std::vector<Piece> solidPieces(const RealizedRoute& realized, double radius) {
  std::vector<Piece> pieces;
  for (std::size_t k = 0; k < realized.straights.size(); ++k) {
    pieces.push_back({realized.straights[k].first, realized.straights[k].second, radius, static_cast<int>(k)});
    if (k < realized.bends.size()) {
      const Bend& bend = realized.bends[k];
      const int chords = std::max(1, static_cast<int>(std::ceil(bend.sweep / (15.0 * kDegree))));
      const double step = bend.sweep / chords;
      const double sagitta = bend.bendRadius * (1.0 - std::cos(0.5 * step));
      for (int c = 0; c < chords; ++c) {
        pieces.push_back({arcPoint(bend, c * step), arcPoint(bend, (c + 1) * step), radius + sagitta, -1});
      }
    }
  }
  return pieces;
}

// ---------------------------------------------------------------------------------------------
// Station placement: which stretches of pipe a scanner station has in sight.

constexpr int kStationCandidates = 48;      // free positions weighed up for the stations
constexpr int kStationDraws = 2000;         // random positions tried to find them
constexpr double kStationClearance = 0.4;   // from every surface but the floor (m)
constexpr double kCrowdedClearance = 0.35;  // when too few positions have kStationClearance
constexpr int kMaxPipeSamples = 1500;       // line-of-sight rays per candidate, at most
constexpr double kMinSampleSpacing = 0.2;   // between samples along a pipe (m)
// What a station is worth, per metre: of a pipe it brings into sight (the pipe receives points),
// of a stretch of pipe it brings into sight, and of a stretch seen again from another side.
constexpr double kNewPipeWeight = 1.0;
constexpr double kNewStretchWeight = 0.3;
constexpr double kRevisitWeight = 0.03;

/// A stretch of a pipe, represented by the middle of its axis.
struct PipeSample {
  Eigen::Vector3d axisPoint, axis;
  double radius = 0.0;
  double length = 0.0;  ///< Of the stretch.
  int pipe = 0;
};

std::vector<PipeSample> samplePipes(const PipeNetwork& network) {
  double total = 0.0;
  for (const Pipe& pipe : network.pipes) total += pipe.length();
  const double spacing = std::max(kMinSampleSpacing, total / kMaxPipeSamples);
  std::vector<PipeSample> samples;
  for (int p = 0; p < static_cast<int>(network.pipes.size()); ++p) {
    const Pipe& pipe = network.pipes[p];
    const int count = std::max(1, static_cast<int>(std::ceil(pipe.length() / spacing)));
    for (int i = 0; i < count; ++i) {
      samples.push_back({pipe.start + ((i + 0.5) / count) * (pipe.end - pipe.start), pipe.direction(), pipe.radius,
                         pipe.length() / count, p});
    }
  }
  return samples;
}

/// Whether the scanner at `station` records the side of the sample facing it: in range, above
/// the blind cone and with nothing in between.
bool inSight(const Scanner& scanner, const Eigen::Vector3d& station, const PipeSample& sample) {
  const ScanSettings limits;  // the scanner's range and blind cone
  Eigen::Vector3d across = station - sample.axisPoint;
  across -= across.dot(sample.axis) * sample.axis;
  const double offAxis = across.norm();
  if (offAxis <= sample.radius) return false;  // looking along the pipe
  // The nearest point of the pipe's surface in the sample's cross-section: the ray meets the
  // pipe there first, so only other surfaces can lie in between.
  const Eigen::Vector3d offset = sample.axisPoint + (sample.radius / offAxis) * across - station;
  const double distance = offset.norm();
  if (distance <= limits.minRange || distance >= limits.maxRange) return false;
  const Ray ray{station, offset / distance};
  if (ray.direction.z() < std::sin(limits.minElevation)) return false;
  return !scanner.occluded(ray, limits.minRange, distance * (1.0 - 1e-9));
}

/// sight[c][k]: whether candidate station c has sample k in sight.
std::vector<std::vector<bool>> lineOfSight(const Scanner& scanner, const std::vector<Eigen::Vector3d>& candidates,
                                           const std::vector<PipeSample>& samples) {
  std::vector<std::vector<bool>> sight(candidates.size(), std::vector<bool>(samples.size()));
  tbb::parallel_for(std::size_t{0}, candidates.size(), [&](std::size_t c) {
    for (std::size_t k = 0; k < samples.size(); ++k) sight[c][k] = inSight(scanner, candidates[c], samples[k]);
  });
  return sight;
}

/// Picks `count` distinct candidates one after the other, each the one that adds the most to
/// what the stations before it see (see the weights above); ties go to the earlier candidate.
std::vector<int> chooseStations(const std::vector<std::vector<bool>>& sight, const std::vector<PipeSample>& samples,
                                const PipeNetwork& network, int count) {
  std::vector<bool> sampleSeen(samples.size(), false), pipeSeen(network.pipes.size(), false);
  std::vector<bool> taken(sight.size(), false);
  std::vector<int> chosen;
  for (int s = 0; s < count; ++s) {
    int best = -1;
    double bestGain = -1.0;
    for (std::size_t c = 0; c < sight.size(); ++c) {
      if (taken[c]) continue;
      std::vector<bool> pipeCounted = pipeSeen;
      double gain = 0.0;
      for (std::size_t k = 0; k < samples.size(); ++k) {
        if (!sight[c][k]) continue;
        gain += (sampleSeen[k] ? kRevisitWeight : kNewStretchWeight) * samples[k].length;
        if (!pipeCounted[samples[k].pipe]) {
          pipeCounted[samples[k].pipe] = true;
          gain += kNewPipeWeight * network.pipes[samples[k].pipe].length();
        }
      }
      if (gain > bestGain) {
        bestGain = gain;
        best = static_cast<int>(c);
      }
    }
    taken[best] = true;
    for (std::size_t k = 0; k < samples.size(); ++k) {
      if (sight[best][k]) sampleSeen[k] = pipeSeen[samples[k].pipe] = true;
    }
    chosen.push_back(best);
  }
  return chosen;
}

// ---------------------------------------------------------------------------------------------
// The layout builder.

enum class Element { None, Pipe, Joint };

struct Blocker {
  OrientedBox box;
  Aabb bounds;
  bool acceptsPipes = false;  ///< Pipes may end in it (floor, walls, equipment).
};

struct Capsule {
  Eigen::Vector3d a, b;
  double radius = 0.0;
  int pipe = -1;  ///< Truth pipe index, or -1 (elbow chords).
  Aabb bounds;
};

struct Termination {
  Eigen::Vector3d point;
  int blocker = -1;
  bool open = false;
};

/// A pipe lying on a rack, from a to b, waiting to be routed off the rack at both ends.
struct RackPipe {
  Eigen::Vector3d a, b;
  double radius = 0.0;
  int radiusIndex = 0;
};

/// The legs grown from a point: corners, then where the last leg ends.
struct Tail {
  std::vector<Eigen::Vector3d> corners;
  Termination end;
};

class LayoutBuilder {
 public:
  LayoutBuilder(const SceneParams& params, int attempt)
      : params_(params),
        config_(presetConfig(params.preset)),
        rng_(params.seed, {0x1a7002, static_cast<std::uint64_t>(attempt)}) {}

  std::optional<SceneLayout> build();

 private:
  // Scene parts.
  void chooseFrame();
  void addRoom();
  void addEquipment();
  bool addPlatform();
  bool addWalkway();
  bool addRackSteel(const Eigen::Vector3d& axis);
  void routeRackPipes(const RackPipe& pipe);
  bool addTeeBranch(bool wantSlope, const Eigen::Vector3d* forcedDirection);
  bool addFreeRun(bool wantSlope, const Eigen::Vector3d* forcedDirection);
  void addHandrail(const Eigen::Vector3d& from, const Eigen::Vector3d& to, double deckHeight,
                   const Eigen::Vector3d& across);
  bool meetsRequirements() const;
  std::optional<std::vector<Eigen::Vector3d>> placeStations(int count);
  SceneLayout finish(std::vector<Eigen::Vector3d> stations);

  // Routing.
  int pickRunSize(int maxIndex);
  Eigen::Vector3d pickDirection(const Eigen::Vector3d& current, bool wantSlope, bool perpendicularOnly,
                                const Eigen::Vector3d* forced);
  std::optional<Tail> growTail(const Eigen::Vector3d& from, const Eigen::Vector3d& heading, double radius, int turns,
                               double firstMin, double firstMax, bool wantSlope);
  std::optional<Termination> terminate(const Eigen::Vector3d& from, const Eigen::Vector3d& direction, double radius,
                                       double minLength, double maxLength) const;
  double roomDistance(const Eigen::Vector3d& from, const Eigen::Vector3d& direction, double inset,
                      double ceiling) const;
  bool insideRoom(const Eigen::Vector3d& p, double inset) const;
  bool hasSlopedLeg(const Route& route) const;
  /// Where a tee branch's surface emerges from its main pipe: no lower than sqrt(R² - r²) from
  /// the main's axis. The stub from there to the branch pipe's start belongs to the tee.
  Eigen::Vector3d teeStubStart(const Route& route) const;
  /// The route's solid pieces, with a tee's stub counted as part of its first straight.
  std::vector<Piece> routePieces(const Route& route, const RealizedRoute& realized) const;
  /// Chooses elbow radii, checks lengths and clearances, and commits. Returns whether it did.
  bool tryCommit(Route route, bool hostsTees);
  bool clear(const Route& route, const RealizedRoute& realized) const;
  bool boxIsFree(const OrientedBox& box, double margin) const;
  void commit(const Route& route, const RealizedRoute& realized, bool hostsTees, bool handrail);

  int addBlocker(const OrientedBox& box, bool acceptsPipes, float reflectance);
  void addSurface(const Shape& shape, Element element, int index, float reflectance);
  int unionFind(int pipe);

  const SceneParams& params_;
  PresetConfig config_;
  Rng rng_;

  double width_ = 0.0, depth_ = 0.0, height_ = 0.0, yaw_ = 0.0;
  std::vector<Eigen::Vector3d> directions_;  // principal directions (unit, sign-free), local frame
  Eigen::Vector3d slope_ = Eigen::Vector3d::Zero();

  std::vector<Blocker> blockers_;
  std::vector<Capsule> capsules_;
  std::vector<int> walls_;           // blocker indices
  std::vector<int> equipment_;       // blocker indices that pipes may start from
  std::vector<RackPipe> rackPipes_;  // laid out with the steel, routed once the equipment stands
  std::vector<Aabb> reserved_;       // space kept free for the rack pipes until they are routed

  PipeNetwork truth_;  // local frame, ids assigned in finish()
  std::vector<int> pipeRadiusIndex_;
  std::vector<bool> pipeHostsTees_;
  std::vector<int> parent_;  // union-find over pipes
  std::vector<Surface> surfaces_;
  std::vector<std::pair<Element, int>> surfaceElements_;
};

// ----- frame, room and distractors -----

void LayoutBuilder::chooseFrame() {
  width_ = rng_.uniform(config_.width[0], config_.width[1]);
  depth_ = rng_.uniform(config_.depth[0], config_.depth[1]);
  height_ = config_.height;
  yaw_ = rng_.uniform(15.0, 75.0) * kDegree;

  const double pitch = rng_.uniform(3.0, 20.0) * kDegree;
  const double draw = rng_.uniform() * (config_.directionOdds[0] + config_.directionOdds[1] + config_.directionOdds[2]);
  const Eigen::Vector3d x = Eigen::Vector3d::UnitX(), y = Eigen::Vector3d::UnitY(), z = Eigen::Vector3d::UnitZ();
  if (draw < config_.directionOdds[0]) {
    // Horizontal runs along h1 and sloped lines across them.
    slope_ = std::cos(pitch) * y + std::sin(pitch) * z;
    directions_ = {x, slope_};
  } else if (draw < config_.directionOdds[0] + config_.directionOdds[1]) {
    slope_ = std::cos(pitch) * x + std::sin(pitch) * z;
    directions_ = {x, z, slope_};
  } else {
    slope_ = std::cos(pitch) * (rng_.chance(0.5) ? x : y) + std::sin(pitch) * z;
    directions_ = {x, y, z, slope_};
  }
}

int LayoutBuilder::addBlocker(const OrientedBox& box, bool acceptsPipes, float reflectance) {
  blockers_.push_back({box, boxBounds(box), acceptsPipes});
  addSurface(box, Element::None, -1, reflectance);
  return static_cast<int>(blockers_.size()) - 1;
}

void LayoutBuilder::addSurface(const Shape& shape, Element element, int index, float reflectance) {
  surfaces_.push_back({shape, 0, reflectance});
  surfaceElements_.emplace_back(element, index);
}

void LayoutBuilder::addRoom() {
  // Concrete floor slab and walls standing outside the room box, so that the room box is free space.
  addBlocker(alignedBox({0.0, 0.0, -kSlab}, {width_, depth_, 0.0}), true, 0.3f);
  const int wallCount = rng_.uniformInt(config_.walls[0], config_.walls[1]);
  // The first wall faces h1 so that runs along h1 can end in it whatever the direction set.
  if (rng_.chance(0.5)) {
    walls_.push_back(addBlocker(alignedBox({-kWall, -kWall, 0.0}, {0.0, depth_ + kWall, height_}), true, 0.65f));
  } else {
    walls_.push_back(
        addBlocker(alignedBox({width_, -kWall, 0.0}, {width_ + kWall, depth_ + kWall, height_}), true, 0.65f));
  }
  if (wallCount > 1) {
    if (rng_.chance(0.5)) {
      walls_.push_back(addBlocker(alignedBox({0.0, depth_, 0.0}, {width_, depth_ + kWall, height_}), true, 0.6f));
    } else {
      walls_.push_back(addBlocker(alignedBox({0.0, -kWall, 0.0}, {width_, 0.0, height_}), true, 0.6f));
    }
  }
}

bool LayoutBuilder::boxIsFree(const OrientedBox& box, double margin) const {
  const Aabb bounds = boxBounds(box);
  for (std::size_t b = kFloor + 1; b < blockers_.size(); ++b) {  // boxes stand on the floor
    if (blockers_[b].bounds.overlaps(bounds, margin)) return false;
  }
  for (const Aabb& space : reserved_) {
    if (space.overlaps(bounds, margin)) return false;
  }
  for (const Capsule& capsule : capsules_) {
    if (!capsule.bounds.overlaps(bounds, margin)) continue;
    if (segmentBoxDistance(capsule.a, capsule.b, box) < capsule.radius + margin) return false;
  }
  return true;
}

void LayoutBuilder::addEquipment() {
  const int count = rng_.uniformInt(config_.equipment[0], config_.equipment[1]);
  const double maxSide = params_.preset == ScenePreset::Small ? 1.6 : 3.5;
  for (int placed = 0, attempt = 0; placed < count && attempt < 40 * count; ++attempt) {
    const double kind = rng_.uniform();
    Eigen::Vector3d size;
    bool acceptsPipes = true;
    double yaw = 0.0;
    if (kind < 0.55) {  // vessels, pumps and skids: pipes connect to them
      size = {rng_.uniform(0.6, maxSide), rng_.uniform(0.5, 0.7 * maxSide),
              rng_.uniform(0.5, std::min(2.6, height_ - 1.4))};
    } else if (kind < 0.8) {  // cabinets
      size = {rng_.uniform(0.6, 1.2), rng_.uniform(0.35, 0.6), rng_.uniform(1.6, 2.1)};
      acceptsPipes = false;
    } else {  // crates and pallets, not square to the building
      size = {rng_.uniform(0.4, 1.0), rng_.uniform(0.4, 1.0), rng_.uniform(0.3, 0.9)};
      yaw = rng_.uniform(-30.0, 30.0) * kDegree;
      acceptsPipes = false;
    }
    if (rng_.chance(0.5)) std::swap(size.x(), size.y());
    const Eigen::Vector2d half = 0.5 * size.head<2>();
    if (width_ < 2 * half.x() + 1.0 || depth_ < 2 * half.y() + 1.0) continue;
    const Eigen::Vector3d center(rng_.uniform(0.4 + half.x(), width_ - 0.4 - half.x()),
                                 rng_.uniform(0.4 + half.y(), depth_ - 0.4 - half.y()), 0.5 * size.z());
    OrientedBox box{center, Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix(), 0.5 * size};
    if (!boxIsFree(box, 0.6)) continue;  // leave walkways between equipment
    const int index = addBlocker(box, acceptsPipes, static_cast<float>(rng_.uniform(0.3, 0.85)));
    if (acceptsPipes) equipment_.push_back(index);
    ++placed;
    if (!acceptsPipes && rng_.chance(0.4)) {  // something stacked on top
      const Eigen::Vector3d top(rng_.uniform(0.3, 1.0) * size.x(), rng_.uniform(0.3, 1.0) * size.y(),
                                rng_.uniform(0.2, 0.5));
      OrientedBox stacked{center + Eigen::Vector3d(0.0, 0.0, 0.5 * size.z() + 0.5 * top.z()), box.axes, 0.5 * top};
      if (boxIsFree(stacked, 0.3)) addBlocker(stacked, false, static_cast<float>(rng_.uniform(0.3, 0.85)));
    }
  }
}

void LayoutBuilder::addHandrail(const Eigen::Vector3d& from, const Eigen::Vector3d& to, double deckHeight,
                                const Eigen::Vector3d& across) {
  // Square posts at most 1.8 m apart carry a top rail at 1.1 m; a mid rail at 0.55 m runs through them.
  const double railRadius = kNominalRadii[kHandrailRadiusIndex];
  const Eigen::Vector3d along = (to - from).normalized();
  const double length = (to - from).norm();
  const int posts = static_cast<int>(std::ceil(length / 1.8)) + 1;
  const double topRail = deckHeight + 1.1;
  for (int i = 0; i < posts; ++i) {
    const Eigen::Vector3d foot = from + (0.025 + (length - 0.05) * i / (posts - 1)) * along;
    const Eigen::Vector3d min = foot - 0.025 * along.cwiseAbs() - 0.025 * across.cwiseAbs();
    const Eigen::Vector3d max = foot + 0.025 * along.cwiseAbs() + 0.025 * across.cwiseAbs();
    addBlocker(alignedBox({min.x(), min.y(), deckHeight}, {max.x(), max.y(), topRail - railRadius}), false, 0.55f);
  }
  for (const double railHeight : {topRail, deckHeight + 0.55}) {
    Route rail;
    rail.radius = railRadius;
    rail.radiusIndex = kHandrailRadiusIndex;
    rail.points = {Eigen::Vector3d(from.x(), from.y(), railHeight), Eigen::Vector3d(to.x(), to.y(), railHeight)};
    rail.startOpen = rail.endOpen = true;
    commit(rail, *realize(rail), false, true);
  }
}

bool LayoutBuilder::addPlatform() {
  // A grating deck on four columns with handrails along its long edges.
  const bool alongY = directions_.size() == 4 && rng_.chance(0.4);
  const Eigen::Vector3d along = alongY ? Eigen::Vector3d::UnitY() : Eigen::Vector3d::UnitX();
  const Eigen::Vector3d across = alongY ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  const double maxLength = params_.preset == ScenePreset::Small ? 3.0 : 7.0;
  const double length = rng_.uniform(2.0, maxLength);
  const double breadth = rng_.uniform(1.2, 2.0);
  const double deck = rng_.uniform(1.2, std::min(3.5, height_ - 2.0));
  const double roomAlong = alongY ? depth_ : width_;
  const double roomAcross = alongY ? width_ : depth_;
  if (roomAlong < length + 1.0 || roomAcross < breadth + 1.0) return false;
  const double a0 = rng_.uniform(0.5, roomAlong - 0.5 - length);
  const double c0 = rng_.uniform(0.5, roomAcross - 0.5 - breadth);
  const Eigen::Vector3d corner = a0 * along + c0 * across;
  const Eigen::Vector3d far = corner + length * along + breadth * across;
  // The whole volume up to the top rail must be free.
  if (!boxIsFree(alignedBox(corner.cwiseMin(far), corner.cwiseMax(far) + Eigen::Vector3d(0, 0, deck + 1.2)), 0.3)) {
    return false;
  }
  addBlocker(alignedBox(corner.cwiseMin(far) + Eigen::Vector3d(0, 0, deck - 0.05),
                        corner.cwiseMax(far) + Eigen::Vector3d(0, 0, deck)),
             false, 0.4f);
  for (const double a : {0.075, length - 0.075}) {
    for (const double c : {0.075, breadth - 0.075}) {
      const Eigen::Vector3d foot = corner + a * along + c * across;
      addBlocker(
          alignedBox(foot - Eigen::Vector3d(0.075, 0.075, 0.0), foot + Eigen::Vector3d(0.075, 0.075, deck - 0.05)),
          false, 0.45f);
    }
  }
  for (const double c : {0.03, breadth - 0.03}) {
    const Eigen::Vector3d start = corner + c * across;
    addHandrail(start, start + length * along, deck, across);
  }
  return true;
}

bool LayoutBuilder::addWalkway() {
  // A guard rail on the floor along a walkway.
  const bool alongY = directions_.size() == 4 && rng_.chance(0.4);
  const Eigen::Vector3d along = alongY ? Eigen::Vector3d::UnitY() : Eigen::Vector3d::UnitX();
  const Eigen::Vector3d across = alongY ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  const double roomAlong = alongY ? depth_ : width_;
  const double roomAcross = alongY ? width_ : depth_;
  const double length = rng_.uniform(2.0, std::min(12.0, roomAlong - 1.0));
  const Eigen::Vector3d start =
      rng_.uniform(0.5, roomAlong - 0.5 - length) * along + rng_.uniform(0.8, roomAcross - 0.8) * across;
  const Eigen::Vector3d end = start + length * along;
  const OrientedBox volume = alignedBox(start.cwiseMin(end) - 0.05 * across.cwiseAbs(),
                                        start.cwiseMax(end) + 0.05 * across.cwiseAbs() + Eigen::Vector3d(0, 0, 1.2));
  if (!boxIsFree(volume, 0.3)) return false;
  addHandrail(start, end, 0.0, across);
  return true;
}

// ----- routing -----

int LayoutBuilder::pickRunSize(int maxIndex) {
  // A quarter small bore (1" to 2"), the rest spread over the larger sizes.
  return rng_.chance(0.25) ? rng_.uniformInt(0, 3) : rng_.uniformInt(3, maxIndex);
}

bool LayoutBuilder::insideRoom(const Eigen::Vector3d& p, double inset) const {
  return p.x() >= inset && p.x() <= width_ - inset && p.y() >= inset && p.y() <= depth_ - inset && p.z() >= inset &&
         p.z() <= height_ - inset;
}

double LayoutBuilder::roomDistance(const Eigen::Vector3d& from, const Eigen::Vector3d& direction, double inset,
                                   double ceiling) const {
  const Eigen::Vector3d low = Eigen::Vector3d::Constant(inset);
  const Eigen::Vector3d high = Eigen::Vector3d(width_, depth_, ceiling) - low;
  double distance = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 3; ++k) {
    if (direction[k] > 1e-12) distance = std::min(distance, (high[k] - from[k]) / direction[k]);
    if (direction[k] < -1e-12) distance = std::min(distance, (low[k] - from[k]) / direction[k]);
  }
  return distance;
}

Eigen::Vector3d LayoutBuilder::pickDirection(const Eigen::Vector3d& current, bool wantSlope, bool perpendicularOnly,
                                             const Eigen::Vector3d* forced) {
  std::vector<std::pair<Eigen::Vector3d, double>> options;
  for (const Eigen::Vector3d& line : directions_) {
    if (forced && !parallel(line, *forced)) continue;
    for (const double sign : {1.0, -1.0}) {
      const Eigen::Vector3d candidate = sign * line;
      const double cosine = candidate.dot(current);
      // Elbows turn by at most 90°; tees branch square to the main pipe.
      if (parallel(candidate, current) || cosine < -1e-9) continue;
      if (perpendicularOnly && std::abs(cosine) > 1e-9) continue;
      double weight = 2.0;
      if (parallel(line, slope_)) {
        weight = wantSlope ? 12.0 : 1.2;
      } else if (candidate.z() < -0.5) {
        weight = 3.0;
      } else if (candidate.z() > 0.5) {
        weight = 0.8;
      }
      options.emplace_back(candidate, weight);
    }
  }
  if (options.empty()) return Eigen::Vector3d::Zero();
  double total = 0.0;
  for (const auto& option : options) total += option.second;
  double draw = rng_.uniform() * total;
  for (const auto& option : options) {
    if ((draw -= option.second) < 0.0) return option.first;
  }
  return options.back().first;
}

std::optional<Termination> LayoutBuilder::terminate(const Eigen::Vector3d& from, const Eigen::Vector3d& direction,
                                                    double radius, double minLength, double maxLength) const {
  // The leg runs on until it meets a box or leaves the site; it may end in the floor, a wall or a
  // piece of equipment (entering close to square), or be cut at an open side of the site.
  const double exit = roomDistance(from, direction, 0.0, height_);
  const Ray ray{from, direction};
  double nearest = std::min(exit, maxLength) + 1e-9;
  int hitBlocker = -1;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  for (int b = 0; b < static_cast<int>(blockers_.size()); ++b) {
    if (auto hit = intersect(blockers_[b].box, ray, 1e-9, nearest)) {
      nearest = hit->distance;
      hitBlocker = b;
      normal = hit->normal;
    }
  }
  if (hitBlocker < 0) {
    // Cut at the site boundary: only through its sides, not the roof or the floor.
    const Eigen::Vector3d end = from + exit * direction;
    const bool side = std::abs(end.z()) > 1e-6 && std::abs(end.z() - height_) > 1e-6;
    if (!side || exit < minLength || exit > maxLength) return std::nullopt;
    return Termination{end, -1, true};
  }
  const Blocker& blocker = blockers_[hitBlocker];
  const double cosine = std::abs(direction.dot(normal));
  if (!blocker.acceptsPipes || cosine < std::cos(kMaxEntryTilt) || nearest < minLength) return std::nullopt;
  // The pipe's whole section must enter the face, not straddle its edge.
  const Eigen::Vector3d end = from + nearest * direction;
  const Eigen::Vector3d local = blocker.box.toLocal(end);
  const Eigen::Vector3d localNormal = blocker.box.axes.transpose() * normal;
  const double footprint = radius / cosine + 0.03;
  for (int k = 0; k < 3; ++k) {
    if (std::abs(localNormal[k]) > 0.5) continue;
    if (std::abs(local[k]) > blocker.box.halfExtents[k] - footprint) return std::nullopt;
  }
  return Termination{end, hitBlocker, false};
}

std::optional<Tail> LayoutBuilder::growTail(const Eigen::Vector3d& from, const Eigen::Vector3d& heading, double radius,
                                            int turns, double firstMin, double firstMax, bool wantSlope) {
  const double longestTangent = 3.0 * radius;  // a 90° long-radius elbow
  const double minLeg = std::max(0.3, 2.0 * longestTangent + kMinStraight);
  const double cornerInset = radius + 0.1;
  Tail tail;
  Eigen::Vector3d point = from;
  Eigen::Vector3d direction = heading;
  for (int turn = 0; turn < turns; ++turn) {
    const double low = turn == 0 ? firstMin : minLeg;
    const double high = std::min(turn == 0 ? firstMax : config_.maxLeg,
                                 roomDistance(point, direction, cornerInset, config_.maxPipeHeight));
    if (high < low) return std::nullopt;
    point += rng_.uniform(low, high) * direction;
    tail.corners.push_back(point);
    direction = pickDirection(direction, wantSlope, false, nullptr);
    if (direction.isZero()) return std::nullopt;
  }
  const double minLength = turns > 0 ? longestTangent + kMinStraight : firstMin;
  // Small-bore lines run short distances; larger ones may cross the site.
  const double maxLength = (radius < 0.04 ? 1.0 : 2.5) * config_.maxLeg;
  const auto end = terminate(point, direction, radius, minLength, maxLength);
  if (!end) return std::nullopt;
  tail.end = *end;
  return tail;
}

bool LayoutBuilder::hasSlopedLeg(const Route& route) const {
  for (std::size_t i = 0; i + 1 < route.points.size(); ++i) {
    if (parallel((route.points[i + 1] - route.points[i]).normalized(), slope_)) return true;
  }
  return false;
}

Eigen::Vector3d LayoutBuilder::teeStubStart(const Route& route) const {
  const double mainRadius = truth_.pipes[route.teeMain].radius;
  const Eigen::Vector3d branch = (route.points.front() - route.teeAxisPoint).normalized();
  return route.teeAxisPoint + std::sqrt(std::max(0.0, mainRadius * mainRadius - route.radius * route.radius)) * branch;
}

std::vector<Piece> LayoutBuilder::routePieces(const Route& route, const RealizedRoute& realized) const {
  std::vector<Piece> pieces = solidPieces(realized, route.radius);
  if (route.teeMain >= 0) pieces.push_back({teeStubStart(route), route.points.front(), route.radius, 0});
  return pieces;
}

bool LayoutBuilder::clear(const Route& route, const RealizedRoute& realized) const {
  const double r = route.radius;
  for (std::size_t i = 1; i + 1 < route.points.size(); ++i) {
    if (!insideRoom(route.points[i], r + 0.05)) return false;
  }
  for (const Eigen::Vector3d& end : {route.points.front(), route.points.back()}) {
    if (!insideRoom(end, -1e-6)) return false;
  }
  const int lastStraight = static_cast<int>(realized.straights.size()) - 1;
  for (const Piece& piece : routePieces(route, realized)) {
    const Aabb bounds = segmentBounds(piece.a, piece.b, piece.radius);
    for (const Capsule& capsule : capsules_) {
      if (piece.straight == 0 && capsule.pipe >= 0 && capsule.pipe == route.teeMain) continue;
      if (!capsule.bounds.overlaps(bounds, kClearance)) continue;
      if (segmentDistance(piece.a, piece.b, capsule.a, capsule.b) < piece.radius + capsule.radius + kClearance) {
        return false;
      }
    }
    for (int b = 0; b < static_cast<int>(blockers_.size()); ++b) {
      if ((piece.straight == 0 && b == route.startBlocker) ||
          (piece.straight == lastStraight && b == route.endBlocker)) {
        continue;
      }
      if (!blockers_[b].bounds.overlaps(bounds, kClearance)) continue;
      if (segmentBoxDistance(piece.a, piece.b, blockers_[b].box) < piece.radius + kClearance) return false;
    }
  }
  // The route must not run into itself (legs two or more apart).
  for (std::size_t i = 0; i + 1 < route.points.size(); ++i) {
    for (std::size_t j = i + 2; j + 1 < route.points.size(); ++j) {
      if (segmentDistance(route.points[i], route.points[i + 1], route.points[j], route.points[j + 1]) <
          2.0 * r + kClearance) {
        return false;
      }
    }
  }
  return true;
}

bool LayoutBuilder::tryCommit(Route route, bool hostsTees) {
  mergeCollinear(route.points);
  if (route.points.size() < 2) return false;
  route.bendRadii.clear();
  for (std::size_t k = 1; k + 1 < route.points.size(); ++k) {
    route.bendRadii.push_back((rng_.chance(kLongRadiusShare) ? 1.5 : 1.0) * 2.0 * route.radius);
  }
  const auto realized = realize(route);
  if (!realized || !clear(route, *realized)) return false;
  commit(route, *realized, hostsTees, false);
  return true;
}

int LayoutBuilder::unionFind(int pipe) {
  while (parent_[pipe] != pipe) pipe = parent_[pipe] = parent_[parent_[pipe]];
  return pipe;
}

void LayoutBuilder::commit(const Route& route, const RealizedRoute& realized, bool hostsTees, bool handrail) {
  const double r = route.radius;
  const auto reflectance = static_cast<float>(handrail ? 0.75 : rng_.uniform(0.35, 0.9));
  const int firstPipe = static_cast<int>(truth_.pipes.size());
  const int lastStraight = static_cast<int>(realized.straights.size()) - 1;

  // How far a straight continues (hidden) into the box it enters, so no rim gap shows.
  auto buriedLength = [&](int blocker, const Eigen::Vector3d& direction) {
    if (blocker < 0) return 0.0;
    const Eigen::Vector3d local = (blockers_[blocker].box.axes.transpose() * direction).cwiseAbs();
    const double cosine = local.maxCoeff();
    return kBuriedLength + r * std::sqrt(std::max(0.0, 1.0 - cosine * cosine)) / cosine;
  };

  for (int k = 0; k <= lastStraight; ++k) {
    const auto& [start, end] = realized.straights[k];
    Pipe pipe;
    pipe.radius = r;
    pipe.start = start;
    pipe.end = end;
    truth_.pipes.push_back(pipe);
    pipeRadiusIndex_.push_back(route.radiusIndex);
    pipeHostsTees_.push_back(hostsTees);
    const int index = static_cast<int>(truth_.pipes.size()) - 1;
    parent_.push_back(k == 0 ? index : firstPipe);

    const Eigen::Vector3d axis = (end - start).normalized();
    const double before = k == 0 ? buriedLength(route.startBlocker, axis) : 0.0;
    const double after = k == lastStraight ? buriedLength(route.endBlocker, axis) : 0.0;
    addSurface(Cylinder{start - before * axis, axis, (end - start).norm() + before + after, r}, Element::Pipe, index,
               reflectance);
    capsules_.push_back({start, end, r, index, segmentBounds(start, end, r)});
  }
  if (route.startOpen) {
    const Eigen::Vector3d axis = (route.points[1] - route.points[0]).normalized();
    addSurface(Disc{route.points.front(), axis, r}, Element::None, -1, reflectance);
  }
  if (route.endOpen) {
    const Eigen::Vector3d axis = (route.points.back() - route.points[route.points.size() - 2]).normalized();
    addSurface(Disc{route.points.back(), axis, r}, Element::None, -1, reflectance);
  }

  for (std::size_t k = 0; k < realized.bends.size(); ++k) {
    const Bend& bend = realized.bends[k];
    Joint elbow;
    elbow.type = JointType::Elbow;
    elbow.pipeIds = {firstPipe + static_cast<int>(k), firstPipe + static_cast<int>(k) + 1};
    elbow.radius = r;
    elbow.bendRadius = bend.bendRadius;
    elbow.axis = sampleArc(bend.center, bend.start, bend.end, kArcStep);
    truth_.joints.push_back(elbow);
    addSurface(TorusSection{bend.center, bend.u, bend.v, bend.bendRadius, r, bend.sweep}, Element::Joint,
               static_cast<int>(truth_.joints.size()) - 1, reflectance);
  }
  for (const Piece& piece : solidPieces(realized, r)) {
    if (piece.straight < 0) {
      capsules_.push_back({piece.a, piece.b, piece.radius, -1, segmentBounds(piece.a, piece.b, piece.radius)});
    }
  }

  if (route.teeMain >= 0) {
    Joint tee;
    tee.type = JointType::Tee;
    tee.pipeIds = {route.teeMain, firstPipe};
    tee.radius = r;
    tee.axis = {route.teeAxisPoint, route.points.front()};
    truth_.joints.push_back(tee);
    const Eigen::Vector3d stubStart = teeStubStart(route);
    const Eigen::Vector3d stub = route.points.front() - stubStart;
    addSurface(Cylinder{stubStart, stub.normalized(), stub.norm(), r}, Element::Joint,
               static_cast<int>(truth_.joints.size()) - 1, reflectance);
    capsules_.push_back({stubStart, route.points.front(), r, -1, segmentBounds(stubStart, route.points.front(), r)});
    parent_[unionFind(firstPipe)] = unionFind(route.teeMain);
  }
}

// ----- runs -----

bool LayoutBuilder::addRackSteel(const Eigen::Vector3d& axis) {
  // Parallel pipes on the cross beams of a row of steel bents, bottoms of pipe level on the beams.
  const bool alongY = axis.y() > 0.5;
  const Eigen::Vector3d across = alongY ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  const double roomAlong = alongY ? depth_ : width_;
  const double roomAcross = alongY ? width_ : depth_;
  const int pipeCount = rng_.uniformInt(config_.rackPipes[0], config_.rackPipes[1]);
  std::vector<std::pair<double, int>> sizes;  // radius, nominal index
  for (int i = 0; i < pipeCount; ++i) {
    const int index = rng_.uniformInt(3, config_.maxRadiusIndex);
    sizes.emplace_back(kNominalRadii[index], index);
  }
  // Largest pipes at the edges, next to the columns, as rack designers do.
  std::sort(sizes.begin(), sizes.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<std::pair<double, int>> order(pipeCount);
  for (int i = 0, left = 0, right = pipeCount - 1; i < pipeCount; ++i) order[i % 2 == 0 ? left++ : right--] = sizes[i];
  const double edge = rng_.uniform(0.1, 0.25);
  std::vector<double> offsets;  // pipe centres across the rack, from its inner edge
  double cursor = edge;
  for (int i = 0; i < pipeCount; ++i) {
    if (i > 0) cursor += rng_.uniform(0.02, 0.08);
    offsets.push_back(cursor + order[i].first);
    cursor += 2.0 * order[i].first;
  }
  const double inner = cursor + edge;  // clear width between the columns
  constexpr double kColumn = 0.2, kBeamDepth = 0.2, kBeamWidth = 0.15;
  const double outer = inner + 2.0 * kColumn;
  if (roomAcross < outer + 1.0) return false;
  const double largest = sizes.front().first;
  const double beamTop = rng_.uniform(config_.rackHeight[0], config_.rackHeight[1]);
  const double shoe = rng_.uniform(0.02, 0.05);
  if (beamTop + shoe + 2.0 * largest > height_ - 0.3) return false;

  // A small room has one rack across it; bigger sites have several, crossing at another height or
  // standing apart.
  const double length =
      params_.preset == ScenePreset::Small ? roomAlong - rng_.uniform(0.6, 2.4) : rng_.uniform(0.45, 0.9) * roomAlong;
  const double start = rng_.uniform(0.3, roomAlong - 0.3 - length);
  const double side = rng_.uniform(0.5, roomAcross - 0.5 - outer);
  const double spacing = params_.preset == ScenePreset::Small ? rng_.uniform(2.5, 3.5) : rng_.uniform(4.0, 6.0);
  const int bents = std::max(2, static_cast<int>(std::ceil(length / spacing)) + 1);

  auto place = [&](double a, double c, double z) -> Eigen::Vector3d {
    return a * axis + c * across + z * Eigen::Vector3d::UnitZ();
  };
  auto box = [&](double a0, double a1, double c0, double c1, double z0, double z1) {
    const Eigen::Vector3d p = place(a0, c0, z0), q = place(a1, c1, z1);
    return alignedBox(p.cwiseMin(q), p.cwiseMax(q));
  };
  std::vector<OrientedBox> steel;
  for (int b = 0; b < bents; ++b) {
    const double a = start + 0.1 + (length - 0.2) * b / (bents - 1);
    steel.push_back(box(a - 0.5 * kColumn, a + 0.5 * kColumn, side, side + kColumn, 0.0, beamTop));
    steel.push_back(box(a - 0.5 * kColumn, a + 0.5 * kColumn, side + outer - kColumn, side + outer, 0.0, beamTop));
    steel.push_back(box(a - 0.5 * kBeamWidth, a + 0.5 * kBeamWidth, side, side + outer, beamTop - kBeamDepth, beamTop));
  }
  for (const double c : {side, side + outer - kColumn}) {
    steel.push_back(box(start + 0.1, start + length - 0.1, c + 0.5 * (kColumn - kBeamWidth),
                        c + 0.5 * (kColumn + kBeamWidth), beamTop - 2.0 * kBeamDepth, beamTop - kBeamDepth));
  }
  for (const OrientedBox& part : steel) {
    if (!boxIsFree(part, 0.25)) return false;
  }
  for (const OrientedBox& part : steel) addBlocker(part, false, 0.45f);

  for (int i = 0; i < pipeCount; ++i) {
    const double radius = order[i].first;
    const double c = side + kColumn + offsets[i];
    const double z = beamTop + shoe + radius;
    rackPipes_.push_back({place(start, c, z), place(start + length, c, z), radius, order[i].second});
  }
  Aabb space;
  space.extend(place(start, side, beamTop));
  space.extend(place(start + length, side + outer, beamTop + shoe + 2.0 * largest));
  reserved_.push_back(space);
  return true;
}

void LayoutBuilder::routeRackPipes(const RackPipe& pipe) {
  const Eigen::Vector3d axis = (pipe.b - pipe.a).normalized();
  for (int attempt = 0; attempt < 12; ++attempt) {
    // Most rack pipes leave the rack by an elbow or two; some run straight on into a wall.
    const auto turnsAt = [&] {
      const double draw = rng_.uniform();
      return draw < 0.25 ? 0 : draw < 0.65 ? 1 : draw < 0.9 ? 2 : 3;
    };
    const auto front = growTail(pipe.a, -axis, pipe.radius, turnsAt(), 0.3, 1.5, false);
    const auto back = growTail(pipe.b, axis, pipe.radius, turnsAt(), 0.3, 1.5, false);
    if (!front || !back) continue;
    Route route;
    route.radius = pipe.radius;
    route.radiusIndex = pipe.radiusIndex;
    route.points.push_back(front->end.point);
    route.points.insert(route.points.end(), front->corners.rbegin(), front->corners.rend());
    route.points.push_back(pipe.a);
    route.points.push_back(pipe.b);
    route.points.insert(route.points.end(), back->corners.begin(), back->corners.end());
    route.points.push_back(back->end.point);
    route.startBlocker = front->end.blocker;
    route.startOpen = front->end.open;
    route.endBlocker = back->end.blocker;
    route.endOpen = back->end.open;
    if (tryCommit(route, true)) return;
  }
}

bool LayoutBuilder::addTeeBranch(bool wantSlope, const Eigen::Vector3d* forcedDirection) {
  std::vector<int> hosts;
  for (int p = 0; p < static_cast<int>(truth_.pipes.size()); ++p) {
    if (pipeHostsTees_[p] && truth_.pipes[p].length() > 0.8) hosts.push_back(p);
  }
  if (hosts.empty()) return false;
  const int main = hosts[rng_.uniformInt(0, static_cast<int>(hosts.size()) - 1)];
  const Pipe& pipe = truth_.pipes[main];
  const Eigen::Vector3d mainDirection = pipe.direction();
  const Eigen::Vector3d branch = pickDirection(mainDirection, wantSlope, true, forcedDirection);
  if (branch.isZero()) return false;
  // Branches are the main's size or up to five sizes smaller.
  const int radiusIndex = rng_.uniformInt(std::max(0, pipeRadiusIndex_[main] - 5), pipeRadiusIndex_[main]);
  const double radius = kNominalRadii[radiusIndex];
  const double margin = radius + 0.25;
  if (pipe.length() < 2.0 * margin) return false;
  const Eigen::Vector3d axisPoint = pipe.start + rng_.uniform(margin, pipe.length() - margin) * mainDirection;
  const Eigen::Vector3d start = axisPoint + pipe.radius * branch;
  const auto tail = growTail(start, branch, radius, rng_.uniformInt(0, 2), 0.3, 1.5, wantSlope);
  if (!tail) return false;
  Route route;
  route.radius = radius;
  route.radiusIndex = radiusIndex;
  route.teeMain = main;
  route.teeAxisPoint = axisPoint;
  route.points.push_back(start);
  route.points.insert(route.points.end(), tail->corners.begin(), tail->corners.end());
  route.points.push_back(tail->end.point);
  route.endBlocker = tail->end.blocker;
  route.endOpen = tail->end.open;
  if (wantSlope && !hasSlopedLeg(route)) return false;
  return tryCommit(route, true);
}

bool LayoutBuilder::addFreeRun(bool wantSlope, const Eigen::Vector3d* forcedDirection) {
  // A run from a nozzle on equipment, out of a wall or up from the floor.
  const int radiusIndex = pickRunSize(config_.maxRadiusIndex - 2);
  const double radius = kNominalRadii[radiusIndex];
  const double kind = rng_.uniform();
  int startBlocker = -1;
  if (kind < 0.45 && !equipment_.empty()) {
    startBlocker = equipment_[rng_.uniformInt(0, static_cast<int>(equipment_.size()) - 1)];
  } else if (kind < 0.8) {
    startBlocker = walls_[rng_.uniformInt(0, static_cast<int>(walls_.size()) - 1)];
  } else {
    startBlocker = kFloor;
  }
  const OrientedBox& box = blockers_[startBlocker].box;
  // Faces whose outward normal is a usable direction (walls and the floor face into the room).
  std::vector<Eigen::Vector3d> faces;
  for (int k = 0; k < 3; ++k) {
    for (const double sign : {1.0, -1.0}) {
      const Eigen::Vector3d normal = sign * box.axes.col(k);
      if (normal.z() < -0.5) continue;
      const Eigen::Vector3d facePoint = box.center + box.halfExtents[k] * normal;
      if (!insideRoom(facePoint + 0.01 * normal, -1e-9)) continue;
      bool usable = false;
      for (const Eigen::Vector3d& line : directions_) usable = usable || parallel(line, normal);
      if (forcedDirection) usable = usable && parallel(normal, *forcedDirection);
      if (usable) faces.push_back(normal);
    }
  }
  if (faces.empty()) return false;
  const Eigen::Vector3d heading = faces[rng_.uniformInt(0, static_cast<int>(faces.size()) - 1)];
  // A point on the face, inside the room and away from the face's edges.
  Eigen::Vector3d local = Eigen::Vector3d::Zero();
  const Eigen::Vector3d localNormal = box.axes.transpose() * heading;
  for (int k = 0; k < 3; ++k) {
    if (std::abs(localNormal[k]) > 0.5) {
      local[k] = localNormal[k] * box.halfExtents[k];
    } else {
      const double reach = box.halfExtents[k] - radius - 0.1;
      if (reach <= 0.0) return false;
      local[k] = rng_.uniform(-reach, reach);
    }
  }
  Eigen::Vector3d start = box.toWorld(local);
  if (heading.z() < 0.5) start.z() = std::min(start.z(), height_ - 0.4);
  // Wall faces run past the room's corners: keep the pipe inside the room across its heading.
  const Eigen::Vector3d roomSize(width_, depth_, height_);
  for (int k = 0; k < 3; ++k) {
    if (std::abs(heading[k]) > 0.5) continue;
    if (start[k] < radius + 0.1 || start[k] > roomSize[k] - radius - 0.1) return false;
  }
  const bool vertical = heading.z() > 0.5;
  const double firstMax = vertical ? std::min(height_ - 1.0, start.z() + 3.0) - start.z() : 1.2;
  const auto tail =
      growTail(start, heading, radius, rng_.uniformInt(1, 3), vertical ? 0.5 : 0.2, std::max(firstMax, 0.6), wantSlope);
  if (!tail) return false;
  Route route;
  route.radius = radius;
  route.radiusIndex = radiusIndex;
  route.points.push_back(start);
  route.points.insert(route.points.end(), tail->corners.begin(), tail->corners.end());
  route.points.push_back(tail->end.point);
  route.startBlocker = startBlocker;
  route.endBlocker = tail->end.blocker;
  route.endOpen = tail->end.open;
  if (wantSlope && !hasSlopedLeg(route)) return false;
  return tryCommit(route, true);
}

// ----- requirements, stations, output -----

bool LayoutBuilder::meetsRequirements() const {
  int elbows = 0, tees = 0;
  for (const Joint& joint : truth_.joints) (joint.type == JointType::Elbow ? elbows : tees) += 1;
  if (elbows == 0 || tees == 0) return false;
  bool sloped = false;
  for (const Pipe& pipe : truth_.pipes) sloped = sloped || parallel(pipe.direction(), slope_);
  return sloped && distinctPipeDirections(truth_, 0.5 * kDegree).size() == directions_.size();
}

std::optional<std::vector<Eigen::Vector3d>> LayoutBuilder::placeStations(int count) {
  // A surveyor sets up where the piping is seen: among free positions for a scanner head
  // (1.5–1.8 m above the floor, clear of everything), each station is the one that brings the
  // most pipe into sight that the stations before it do not see.
  auto clearance = [&](const Eigen::Vector3d& p) {
    double nearest = std::numeric_limits<double>::infinity();
    for (std::size_t b = kFloor + 1; b < blockers_.size(); ++b) {
      nearest = std::min(nearest, pointBoxDistance(p, blockers_[b].box));
    }
    for (const Capsule& capsule : capsules_) {
      nearest = std::min(nearest, pointSegmentDistance(p, capsule.a, capsule.b) - capsule.radius);
    }
    return nearest;
  };
  std::vector<Eigen::Vector3d> candidates;
  for (const double required : {kStationClearance, kCrowdedClearance}) {
    candidates.clear();
    for (int draw = 0; draw < kStationDraws && static_cast<int>(candidates.size()) < kStationCandidates; ++draw) {
      const Eigen::Vector3d p(rng_.uniform(0.8, width_ - 0.8), rng_.uniform(0.8, depth_ - 0.8),
                              rng_.uniform(1.5, 1.8));
      if (clearance(p) >= required) candidates.push_back(p);
    }
    if (static_cast<int>(candidates.size()) >= count) break;
  }
  if (static_cast<int>(candidates.size()) < count) return std::nullopt;

  const std::vector<PipeSample> samples = samplePipes(truth_);
  const auto sight = lineOfSight(Scanner(surfaces_), candidates, samples);
  std::vector<Eigen::Vector3d> stations;
  for (const int c : chooseStations(sight, samples, truth_, count)) stations.push_back(candidates[c]);
  return stations;
}

SceneLayout LayoutBuilder::finish(std::vector<Eigen::Vector3d> stations) {
  const Eigen::Matrix3d rotation = Eigen::AngleAxisd(yaw_, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d shift(-0.5 * width_, -0.5 * depth_, 0.0);
  auto toWorld = [&](const Eigen::Vector3d& p) -> Eigen::Vector3d { return rotation * (p + shift); };

  SceneLayout layout;
  const int pipeCount = static_cast<int>(truth_.pipes.size());
  auto pipeId = [](int index) { return index + 1; };
  auto jointId = [&](int index) { return pipeCount + index + 1; };

  // Runs: connected components, numbered in order of their first pipe.
  std::vector<int> runOfRoot(pipeCount, -1);
  for (int p = 0; p < pipeCount; ++p) {
    const int root = unionFind(p);
    if (runOfRoot[root] < 0) {
      runOfRoot[root] = static_cast<int>(layout.truth.runs.size());
      layout.truth.runs.push_back(Run{static_cast<int>(layout.truth.runs.size()) + 1, {}, {}});
    }
  }
  for (int p = 0; p < pipeCount; ++p) {
    Pipe pipe = truth_.pipes[p];
    pipe.id = pipeId(p);
    pipe.start = toWorld(pipe.start);
    pipe.end = toWorld(pipe.end);
    Run& run = layout.truth.runs[runOfRoot[unionFind(p)]];
    pipe.runId = run.id;
    run.pipeIds.push_back(pipe.id);
    layout.truth.pipes.push_back(pipe);
  }
  for (int j = 0; j < static_cast<int>(truth_.joints.size()); ++j) {
    Joint joint = truth_.joints[j];
    joint.id = jointId(j);
    layout.truth.runs[runOfRoot[unionFind(joint.pipeIds.front())]].jointIds.push_back(joint.id);
    for (int& pipe : joint.pipeIds) pipe = pipeId(pipe);
    for (Eigen::Vector3d& point : joint.axis) point = toWorld(point);
    layout.truth.joints.push_back(std::move(joint));
  }
  layout.truth.validate();

  for (std::size_t s = 0; s < surfaces_.size(); ++s) {
    Surface surface = surfaces_[s];
    const auto [element, index] = surfaceElements_[s];
    surface.label = element == Element::Pipe ? pipeId(index) : element == Element::Joint ? jointId(index) : 0;
    std::visit(
        [&](auto& shape) {
          using T = std::decay_t<decltype(shape)>;
          if constexpr (std::is_same_v<T, Cylinder>) {
            shape.start = toWorld(shape.start);
            shape.axis = rotation * shape.axis;
          } else if constexpr (std::is_same_v<T, TorusSection>) {
            shape.center = toWorld(shape.center);
            shape.u = rotation * shape.u;
            shape.v = rotation * shape.v;
          } else if constexpr (std::is_same_v<T, OrientedBox>) {
            shape.center = toWorld(shape.center);
            shape.axes = rotation * shape.axes;
          } else {
            shape.center = toWorld(shape.center);
            shape.normal = rotation * shape.normal;
          }
        },
        surface.shape);
    layout.surfaces.push_back(std::move(surface));
  }
  layout.room = OrientedBox{toWorld(Eigen::Vector3d(0.5 * width_, 0.5 * depth_, 0.5 * height_)), rotation,
                            Eigen::Vector3d(0.5 * width_, 0.5 * depth_, 0.5 * height_)};
  // The roof covers the walls too, which stand outside the room box.
  layout.roof = Surface{OrientedBox{toWorld(Eigen::Vector3d(0.5 * width_, 0.5 * depth_, height_ + 0.5 * kSlab)), rotation,
                                    Eigen::Vector3d(0.5 * width_ + kWall, 0.5 * depth_ + kWall, 0.5 * kSlab)},
                        0, 0.3f};
  for (const Eigen::Vector3d& station : stations) layout.stations.push_back(toWorld(station));
  return layout;
}

std::optional<SceneLayout> LayoutBuilder::build() {
  chooseFrame();
  addRoom();
  // Racks first: they carry most pipes and span the site. The first runs along h1, the next
  // along h2 when the scene has it, and so on.
  const int racks = rng_.uniformInt(config_.racks[0], config_.racks[1]);
  const bool hasY = directions_.size() == 4;
  for (int placed = 0, attempt = 0; placed < racks && attempt < 20 * racks; ++attempt) {
    const Eigen::Vector3d axis = (hasY && placed % 2 == 1) ? Eigen::Vector3d::UnitY() : Eigen::Vector3d::UnitX();
    placed += addRackSteel(axis);
  }
  addEquipment();
  const int platforms = rng_.uniformInt(config_.platforms[0], config_.platforms[1]);
  for (int placed = 0, attempt = 0; placed < platforms && attempt < 20 * platforms; ++attempt) placed += addPlatform();
  const int walkways = rng_.uniformInt(config_.walkways[0], config_.walkways[1]);
  for (int placed = 0, attempt = 0; placed < walkways && attempt < 20 * walkways; ++attempt) placed += addWalkway();
  for (const RackPipe& pipe : rackPipes_) routeRackPipes(pipe);

  const int slopedRuns = rng_.uniformInt(config_.slopedRuns[0], config_.slopedRuns[1]);
  for (int placed = 0, attempt = 0; placed < slopedRuns && attempt < 60 * slopedRuns; ++attempt) {
    placed += rng_.chance(0.5) ? addTeeBranch(true, nullptr) : addFreeRun(true, nullptr);
  }
  const int targetPipes = rng_.uniformInt(config_.pipes[0], config_.pipes[1]);
  for (int attempt = 0; static_cast<int>(truth_.pipes.size()) < targetPipes && attempt < 40 * targetPipes; ++attempt) {
    if (rng_.chance(0.5)) {
      addTeeBranch(false, nullptr);
    } else {
      addFreeRun(false, nullptr);
    }
  }

  // Make sure of what every scene must show: a tee, a sloped pipe and each principal direction.
  for (int attempt = 0; attempt < 200 && !meetsRequirements(); ++attempt) {
    bool hasTee = false;
    for (const Joint& joint : truth_.joints) hasTee = hasTee || joint.type == JointType::Tee;
    if (!hasTee) {
      addTeeBranch(false, nullptr);
      continue;
    }
    const auto used = distinctPipeDirections(truth_, 0.5 * kDegree);
    const Eigen::Vector3d* missing = nullptr;
    for (const Eigen::Vector3d& line : directions_) {
      bool present = false;
      for (const Eigen::Vector3d& u : used) present = present || parallel(u, line);
      if (!present) missing = &line;
    }
    if (missing && parallel(*missing, slope_)) missing = nullptr;  // a sloped run supplies it
    if (missing) {
      rng_.chance(0.5) ? addTeeBranch(false, missing) : addFreeRun(false, missing);
    } else {
      rng_.chance(0.5) ? addTeeBranch(true, nullptr) : addFreeRun(true, nullptr);
    }
  }
  if (!meetsRequirements()) return std::nullopt;

  const int stationCount = params_.stations > 0 ? params_.stations : rng_.uniformInt(1, 3);
  auto stations = placeStations(stationCount);
  if (!stations) return std::nullopt;
  return finish(std::move(*stations));
}

}  // namespace

std::vector<Eigen::Vector3d> distinctPipeDirections(const PipeNetwork& network, double toleranceRadians) {
  std::vector<Eigen::Vector3d> lines;
  const double minCosine = std::cos(toleranceRadians);
  for (const Pipe& pipe : network.pipes) {
    const Eigen::Vector3d direction = pipe.direction();
    if (direction.isZero()) continue;
    bool known = false;
    for (const Eigen::Vector3d& line : lines) known = known || std::abs(line.dot(direction)) >= minCosine;
    if (!known) lines.push_back(direction);
  }
  return lines;
}

SceneLayout buildSceneLayout(const SceneParams& params) {
  if (params.stations < 0 || params.stations > 3) {
    throw std::invalid_argument("scene stations must be 0 (chosen by the seed) to 3, got " +
                                std::to_string(params.stations));
  }
  constexpr int kAttempts = 25;
  for (int attempt = 0; attempt < kAttempts; ++attempt) {
    if (auto layout = LayoutBuilder(params, attempt).build()) return std::move(*layout);
  }
  throw std::runtime_error("no scene layout met the requirements after " + std::to_string(kAttempts) + " tries");
}

}  // namespace piperun::synth
