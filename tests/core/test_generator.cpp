// Tests of the synthetic scene generator: determinism, the truth network, and the simulated scan.

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <stdexcept>
#include <vector>

#include "piperun/synth/scene_generator.h"
#include "synth/scanner.h"
#include "synth/scene_layout.h"

namespace piperun {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegree = kPi / 180.0;

/// Everything a generation run hands out, kept in world coordinates (double).
struct Collected {
  PipeNetwork truth;
  SceneSummary summary;
  std::vector<Eigen::Vector3d> positions;
  std::vector<float> intensities;
  std::vector<std::int32_t> labels;
  std::size_t chunks = 0;
  std::size_t largestChunk = 0;
  bool consistentChunks = true;
};

Collected collect(const SceneParams& params) {
  Collected out;
  out.summary = generateScene(params, out.truth, [&](const PointChunk& chunk) {
    ++out.chunks;
    out.largestChunk = std::max(out.largestChunk, chunk.size());
    out.consistentChunks = out.consistentChunks && chunk.normals.empty() && chunk.colors.empty() &&
                           chunk.intensities.size() == chunk.size() && chunk.labels.size() == chunk.size();
    out.positions.insert(out.positions.end(), chunk.positions.begin(), chunk.positions.end());
    out.intensities.insert(out.intensities.end(), chunk.intensities.begin(), chunk.intensities.end());
    out.labels.insert(out.labels.end(), chunk.labels.begin(), chunk.labels.end());
  });
  return out;
}

SceneParams reducedSmall(std::uint64_t seed) {
  SceneParams params;
  params.preset = ScenePreset::Small;
  params.seed = seed;
  params.densityScale = 0.2;
  return params;
}

void expectSameNetwork(const PipeNetwork& a, const PipeNetwork& b) {
  ASSERT_EQ(a.pipes.size(), b.pipes.size());
  ASSERT_EQ(a.joints.size(), b.joints.size());
  ASSERT_EQ(a.runs.size(), b.runs.size());
  for (std::size_t i = 0; i < a.pipes.size(); ++i) {
    EXPECT_EQ(a.pipes[i].id, b.pipes[i].id);
    EXPECT_EQ(a.pipes[i].start, b.pipes[i].start);
    EXPECT_EQ(a.pipes[i].end, b.pipes[i].end);
    EXPECT_EQ(a.pipes[i].radius, b.pipes[i].radius);
    EXPECT_EQ(a.pipes[i].runId, b.pipes[i].runId);
    EXPECT_EQ(a.pipes[i].inlierCount, b.pipes[i].inlierCount);
  }
  for (std::size_t i = 0; i < a.joints.size(); ++i) {
    EXPECT_EQ(a.joints[i].id, b.joints[i].id);
    EXPECT_EQ(a.joints[i].type, b.joints[i].type);
    EXPECT_EQ(a.joints[i].pipeIds, b.joints[i].pipeIds);
    EXPECT_EQ(a.joints[i].axis, b.joints[i].axis);
  }
}

void expectSamePoints(const Collected& a, const Collected& b) {
  ASSERT_EQ(a.positions.size(), b.positions.size());
  EXPECT_TRUE(a.positions == b.positions);
  EXPECT_TRUE(a.intensities == b.intensities);
  EXPECT_TRUE(a.labels == b.labels);
}

/// Distance from p to the infinite line through the pipe's axis, and p's position along the axis.
std::pair<double, double> axisCoordinates(const Pipe& pipe, const Eigen::Vector3d& p) {
  const Eigen::Vector3d axis = pipe.direction();
  const double along = (p - pipe.start).dot(axis);
  return {(p - pipe.start - along * axis).norm(), along};
}

/// Distance from p to an elbow's centre line (its sampled arc).
double distanceToPolyline(const std::vector<Eigen::Vector3d>& polyline, const Eigen::Vector3d& p) {
  double nearest = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i + 1 < polyline.size(); ++i) {
    const Eigen::Vector3d ab = polyline[i + 1] - polyline[i];
    const double t = std::clamp((p - polyline[i]).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
    nearest = std::min(nearest, (polyline[i] + t * ab - p).norm());
  }
  return nearest;
}

bool isElbow(const PipeNetwork& network, int id) {
  const Joint* joint = network.findJoint(id);
  return joint && joint->type == JointType::Elbow;
}

TEST(GeneratorTest, SameParamsGiveSamePointsAndTruth) {
  const Collected first = collect(reducedSmall(7));
  const Collected second = collect(reducedSmall(7));
  expectSamePoints(first, second);
  expectSameNetwork(first.truth, second.truth);
}

TEST(GeneratorTest, DifferentSeedsGiveDifferentScenes) {
  const Collected first = collect(reducedSmall(7));
  const Collected other = collect(reducedSmall(8));
  const bool sameLayout = first.truth.pipes.size() == other.truth.pipes.size() &&
                          first.truth.pipes.front().start == other.truth.pipes.front().start;
  EXPECT_FALSE(sameLayout);
  EXPECT_FALSE(first.positions == other.positions);
}

TEST(GeneratorTest, OutputDoesNotDependOnThreadCount) {
  Collected single, dual;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    single = collect(reducedSmall(3));
  }
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
    dual = collect(reducedSmall(3));
  }
  expectSamePoints(single, dual);
  expectSameNetwork(single.truth, dual.truth);
}

TEST(GeneratorTest, TruthNetworksMeetTheSceneRequirements) {
  for (const ScenePreset preset : {ScenePreset::Small, ScenePreset::Medium}) {
    for (std::uint64_t seed = 1; seed <= 8; ++seed) {
      SCOPED_TRACE(toString(preset) + " seed " + std::to_string(seed));
      SceneParams params;
      params.preset = preset;
      params.seed = seed;
      const PipeNetwork truth = synth::buildSceneLayout(params).truth;
      ASSERT_NO_THROW(truth.validate());

      int elbows = 0, tees = 0, sloped = 0, skewed = 0;
      for (const Pipe& pipe : truth.pipes) {
        EXPECT_GE(pipe.radius, 0.015);
        EXPECT_LE(pipe.radius, 0.30);
        EXPECT_GT(pipe.length(), 0.05);
        const Eigen::Vector3d d = pipe.direction();
        const double pitch = std::asin(std::abs(d.z())) / kDegree;
        if (pitch > 2.9 && pitch < 20.1) ++sloped;
        const bool axisAligned = d.cwiseAbs().maxCoeff() > std::cos(0.5 * kDegree);
        if (!axisAligned) ++skewed;
        // Every pipe is in the run it names.
        const auto run = std::find_if(truth.runs.begin(), truth.runs.end(),
                                      [&](const piperun::Run& r) { return r.id == pipe.runId; });
        ASSERT_NE(run, truth.runs.end());
        EXPECT_NE(std::find(run->pipeIds.begin(), run->pipeIds.end(), pipe.id), run->pipeIds.end());
      }
      for (const Joint& joint : truth.joints) {
        ASSERT_EQ(joint.pipeIds.size(), 2u);
        const Pipe* a = truth.findPipe(joint.pipeIds[0]);
        const Pipe* b = truth.findPipe(joint.pipeIds[1]);
        ASSERT_TRUE(a && b);
        EXPECT_EQ(a->runId, b->runId);
        if (joint.type == JointType::Elbow) {
          ++elbows;
          EXPECT_EQ(joint.radius, a->radius);
          EXPECT_GE(joint.bendRadius, 2.0 * joint.radius * (1.0 - 1e-9));
          EXPECT_LE(joint.bendRadius, 3.0 * joint.radius * (1.0 + 1e-9));
          // The arc runs from the end of one pipe to the start of the next, sampled every 1 cm or finer.
          EXPECT_LT((joint.axis.front() - a->end).norm(), 1e-9);
          EXPECT_LT((joint.axis.back() - b->start).norm(), 1e-9);
          for (std::size_t i = 0; i + 1 < joint.axis.size(); ++i) {
            EXPECT_LE((joint.axis[i + 1] - joint.axis[i]).norm(), 0.01 + 1e-9);
          }
        } else {
          ASSERT_EQ(joint.type, JointType::Tee);
          ++tees;
          // Main pipe continuous through the tee; the branch starts on its surface, square to it.
          ASSERT_EQ(joint.axis.size(), 2u);
          EXPECT_LE(b->radius, a->radius);
          EXPECT_EQ(joint.radius, b->radius);
          const auto [offAxis, along] = axisCoordinates(*a, joint.axis.front());
          EXPECT_LT(offAxis, 1e-9);
          EXPECT_GT(along, b->radius);
          EXPECT_LT(along, a->length() - b->radius);
          EXPECT_LT((joint.axis.back() - b->start).norm(), 1e-9);
          EXPECT_NEAR((joint.axis.back() - joint.axis.front()).norm(), a->radius, 1e-9);
          EXPECT_NEAR(a->direction().dot(b->direction()), 0.0, 1e-9);
        }
      }
      EXPECT_GE(elbows, 1);
      EXPECT_GE(tees, 1);
      EXPECT_GE(sloped, 1);
      EXPECT_GE(skewed, 1);
      const auto directions = synth::distinctPipeDirections(truth, 0.5 * kDegree).size();
      EXPECT_GE(directions, 2u);
      EXPECT_LE(directions, 4u);
    }
  }
}

TEST(GeneratorTest, PipesDoNotInterpenetrate) {
  // Straight pipes of different runs keep their surfaces apart (sampled distance between axes).
  const PipeNetwork truth = synth::buildSceneLayout(SceneParams{}).truth;
  for (std::size_t i = 0; i < truth.pipes.size(); ++i) {
    for (std::size_t j = i + 1; j < truth.pipes.size(); ++j) {
      const Pipe& a = truth.pipes[i];
      const Pipe& b = truth.pipes[j];
      if (a.runId == b.runId) continue;
      double nearest = std::numeric_limits<double>::infinity();
      const int samples = 200;
      for (int k = 0; k <= samples; ++k) {
        const Eigen::Vector3d p = a.start + (a.end - a.start) * (static_cast<double>(k) / samples);
        const Eigen::Vector3d ab = b.end - b.start;
        const double t = std::clamp((p - b.start).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
        nearest = std::min(nearest, (b.start + t * ab - p).norm());
      }
      EXPECT_GT(nearest, a.radius + b.radius) << "pipes " << a.id << " and " << b.id;
    }
  }
}

TEST(GeneratorTest, SummaryMatchesPointsAndTruth) {
  const Collected scene = collect(reducedSmall(5));
  EXPECT_EQ(scene.summary.points, scene.positions.size());
  EXPECT_EQ(scene.summary.outliers,
            static_cast<std::uint64_t>(std::count(scene.labels.begin(), scene.labels.end(), -1)));
  EXPECT_EQ(scene.summary.pipes, static_cast<int>(scene.truth.pipes.size()));
  EXPECT_EQ(scene.summary.runs, static_cast<int>(scene.truth.runs.size()));
  EXPECT_EQ(scene.summary.elbows + scene.summary.tees, static_cast<int>(scene.truth.joints.size()));
  EXPECT_GE(scene.summary.stations, 1);
  EXPECT_LE(scene.summary.stations, 3);
  EXPECT_GE(scene.summary.directions, 2);
  EXPECT_LE(scene.summary.directions, 4);
  for (const Eigen::Vector3d& p : scene.positions) {
    ASSERT_TRUE((p.array() >= scene.summary.bounds.min.array()).all() &&
                (p.array() <= scene.summary.bounds.max.array()).all());
  }
  std::map<int, std::int64_t> perPipe;
  for (const std::int32_t label : scene.labels) ++perPipe[label];
  for (const Pipe& pipe : scene.truth.pipes) EXPECT_EQ(pipe.inlierCount, perPipe[pipe.id]);
  EXPECT_TRUE(scene.consistentChunks);
  for (const float intensity : scene.intensities) ASSERT_TRUE(intensity >= 0.0f && intensity <= 1.0f);
}

TEST(GeneratorTest, InMemorySceneMatchesStreamedPoints) {
  const Collected streamed = collect(reducedSmall(2));
  const GeneratedScene scene = generateScene(reducedSmall(2));
  ASSERT_EQ(scene.cloud.size(), streamed.positions.size());
  EXPECT_FALSE(scene.cloud.hasNormals());
  EXPECT_TRUE(scene.cloud.labels == streamed.labels);
  for (std::size_t i = 0; i < scene.cloud.size(); i += 97) {
    EXPECT_LT((scene.cloud.worldPosition(i) - streamed.positions[i]).norm(), 1e-5);
  }
  expectSameNetwork(scene.truth, streamed.truth);
}

TEST(GeneratorTest, PointsLieOnTheElementTheyAreLabelledWith) {
  SceneParams params = reducedSmall(4);
  params.densityScale = 0.5;
  const Collected scene = collect(params);
  const double tolerance = 5.0 * params.noiseSigma + 0.001;
  std::size_t pipePoints = 0, elbowPoints = 0;
  for (std::size_t i = 0; i < scene.positions.size(); ++i) {
    const int label = scene.labels[i];
    if (label <= 0) continue;
    if (const Pipe* pipe = scene.truth.findPipe(label)) {
      const auto [offAxis, along] = axisCoordinates(*pipe, scene.positions[i]);
      ASSERT_NEAR(offAxis, pipe->radius, tolerance) << "pipe " << label;
      // Within the pipe, give or take the rim of an end that enters a surface at a slant.
      const double rim = pipe->radius * std::tan(25.0 * kDegree) + tolerance;
      ASSERT_GT(along, -rim);
      ASSERT_LT(along, pipe->length() + rim);
      ++pipePoints;
    } else if (isElbow(scene.truth, label)) {
      const Joint& elbow = *scene.truth.findJoint(label);
      // The sampled arc cuts inside the true arc by at most its sagitta, step² / (8 R).
      const double sagitta = 0.01 * 0.01 / (8.0 * elbow.bendRadius);
      ASSERT_NEAR(distanceToPolyline(elbow.axis, scene.positions[i]), elbow.radius, tolerance + sagitta);
      ++elbowPoints;
    }
  }
  EXPECT_GT(pipePoints, 1000u);
  EXPECT_GT(elbowPoints, 10u);
}

TEST(GeneratorTest, NoiseFreePointsAreOnTheSurfaces) {
  SceneParams params = reducedSmall(4);
  params.noiseSigma = 0.0;
  params.outlierFraction = 0.0;
  const Collected scene = collect(params);
  EXPECT_EQ(scene.summary.outliers, 0u);
  std::size_t checked = 0;
  for (std::size_t i = 0; i < scene.positions.size(); ++i) {
    const Pipe* pipe = scene.truth.findPipe(scene.labels[i]);
    if (!pipe) continue;
    ASSERT_NEAR(axisCoordinates(*pipe, scene.positions[i]).first, pipe->radius, 1e-5);
    ++checked;
  }
  EXPECT_GT(checked, 500u);
}

TEST(GeneratorTest, OutlierShareMatchesTheFraction) {
  SceneParams params = reducedSmall(6);
  params.outlierFraction = 0.05;
  const Collected scene = collect(params);
  const double surfacePoints = static_cast<double>(scene.summary.points - scene.summary.outliers);
  EXPECT_NEAR(static_cast<double>(scene.summary.outliers) / surfacePoints, 0.05, 0.005);
}

TEST(GeneratorTest, SmallPresetHasAboutThreeHundredThousandPoints) {
  for (const std::uint64_t seed : {1u, 2u}) {
    SceneParams params;
    params.seed = seed;
    const Collected scene = collect(params);
    EXPECT_GT(scene.summary.points, 210000u);
    EXPECT_LT(scene.summary.points, 390000u);
    EXPECT_GT(scene.chunks, 1u);
    EXPECT_LE(scene.largestChunk, 300000u);
    EXPECT_GE(scene.truth.pipes.size(), 8u);
    EXPECT_LE(scene.truth.pipes.size(), 35u);
  }
}

TEST(GeneratorTest, DensityScaleScalesThePointCount) {
  SceneParams params = reducedSmall(9);
  const double reduced = static_cast<double>(collect(params).summary.points);
  params.densityScale = 0.4;
  const double doubled = static_cast<double>(collect(params).summary.points);
  EXPECT_NEAR(doubled / reduced, 2.0, 0.2);
}

TEST(GeneratorTest, OneStationSeesPipesFromOneSide) {
  for (const std::uint64_t seed : {1u, 2u, 3u}) {
    SceneParams params = reducedSmall(seed);
    params.stations = 1;
    params.densityScale = 0.5;
    const Collected scene = collect(params);
    EXPECT_EQ(scene.summary.stations, 1);
    std::map<int, std::vector<double>> angles;
    for (std::size_t i = 0; i < scene.positions.size(); ++i) {
      const Pipe* pipe = scene.truth.findPipe(scene.labels[i]);
      if (!pipe) continue;
      const Eigen::Vector3d axis = pipe->direction();
      const Eigen::Vector3d u = axis.unitOrthogonal(), v = axis.cross(u);
      const Eigen::Vector3d radial = scene.positions[i] - pipe->start;
      angles[pipe->id].push_back(std::atan2(radial.dot(v), radial.dot(u)));
    }
    int measured = 0;
    for (auto& [id, list] : angles) {
      if (list.size() < 50) continue;
      std::sort(list.begin(), list.end());
      double largestGap = list.front() + 2.0 * kPi - list.back();
      for (std::size_t k = 0; k + 1 < list.size(); ++k) largestGap = std::max(largestGap, list[k + 1] - list[k]);
      EXPECT_LT(360.0 - largestGap / kDegree, 200.0) << "seed " << seed << " pipe " << id;
      ++measured;
    }
    EXPECT_GT(measured, 0);
  }
}

TEST(GeneratorTest, MisregisteredStationsMoveRigidlyAndTheFirstStays) {
  SceneParams params = reducedSmall(4);
  params.stations = 3;
  params.noiseSigma = 0.0;
  params.outlierFraction = 0.0;
  const Collected registered = collect(params);
  constexpr double kError = 0.005;
  params.registrationError = kError;
  const Collected misregistered = collect(params);

  // The same rays hit the same surfaces; only where their points land differs.
  ASSERT_EQ(registered.positions.size(), misregistered.positions.size());
  EXPECT_TRUE(registered.labels == misregistered.labels);
  EXPECT_TRUE(registered.intensities == misregistered.intensities);
  expectSameNetwork(registered.truth, misregistered.truth);

  // The first station's points come first and stay where they were.
  const std::size_t count = registered.positions.size();
  std::size_t firstMoved = 0;
  while (firstMoved < count && registered.positions[firstMoved] == misregistered.positions[firstMoved]) ++firstMoved;
  ASSERT_GT(firstMoved, 0u);
  ASSERT_LT(firstMoved, count);

  // The later stations' points move rigidly: by about the error (the shift plus the turn about the
  // station, error per 10 m), and the distance between two points scanned one after the other is
  // kept except where one station's points give way to the next's.
  std::vector<double> moves;
  int distancesChanged = 0;
  for (std::size_t i = firstMoved; i < count; ++i) {
    moves.push_back((misregistered.positions[i] - registered.positions[i]).norm());
    if (i + 1 < count) {
      const double before = (registered.positions[i + 1] - registered.positions[i]).norm();
      const double after = (misregistered.positions[i + 1] - misregistered.positions[i]).norm();
      if (std::fabs(after - before) > 1e-9) ++distancesChanged;
    }
  }
  EXPECT_LE(distancesChanged, 1);
  std::sort(moves.begin(), moves.end());
  EXPECT_GT(moves.front(), 0.0);
  EXPECT_LT(moves.back(), 3.0 * kError);
  EXPECT_NEAR(moves[moves.size() / 2], kError, 0.5 * kError);
}

TEST(GeneratorTest, MixedPixelsLieOnTheirRayBetweenTheSurfacesOfAnEdge) {
  SceneParams params = reducedSmall(2);
  params.stations = 1;
  params.outlierFraction = 0.0;
  const Collected clean = collect(params);
  params.mixedPixelShare = 1.0;
  const Collected mixed = collect(params);
  params.mixedPixelShare = 0.5;
  const Collected halfMixed = collect(params);
  const Eigen::Vector3d station = synth::buildSceneLayout(params).stations.front();

  // A mixed pixel takes the place of its ray's point; every other point keeps its noise.
  ASSERT_EQ(clean.positions.size(), mixed.positions.size());
  std::size_t mixedCount = 0;
  for (std::size_t i = 0; i < clean.positions.size(); ++i) {
    if (mixed.positions[i] == clean.positions[i]) {
      EXPECT_EQ(mixed.labels[i], clean.labels[i]);
      continue;
    }
    ++mixedCount;
    EXPECT_EQ(mixed.labels[i], -1);
    EXPECT_GE(clean.labels[i], 0);
    // On the ray of the surface point: the noise moved that point off the ray by a few σ at most,
    // which the line through it turns into that much times the ranges' ratio.
    const Eigen::Vector3d toPoint = clean.positions[i] - station, offset = mixed.positions[i] - station;
    const Eigen::Vector3d ray = toPoint.normalized();
    EXPECT_LT((offset - offset.dot(ray) * ray).norm(), 5.0 * params.noiseSigma * offset.norm() / toPoint.norm());
  }
  EXPECT_EQ(mixedCount, mixed.summary.mixedPixels);
  // Edges are a few per cent of the rays; half the share mixes about half of them.
  const double share = static_cast<double>(mixedCount) / static_cast<double>(clean.positions.size());
  EXPECT_GT(share, 0.01);
  EXPECT_LT(share, 0.2);
  EXPECT_NEAR(static_cast<double>(halfMixed.summary.mixedPixels) / static_cast<double>(mixedCount), 0.5, 0.05);
  EXPECT_EQ(clean.summary.mixedPixels, 0u);
}

TEST(GeneratorTest, ARoofAddsItsPointsOverTheRoomAndTakesNoneFromThePipes) {
  SceneParams params = reducedSmall(3);
  const Collected open = collect(params);
  params.roof = true;
  const Collected roofed = collect(params);
  // The sampling is the open scene's: every pipe and joint keeps its hits (the truth's counts).
  expectSameNetwork(open.truth, roofed.truth);
  ASSERT_GT(roofed.positions.size(), open.positions.size());
  // The points added are the roof's (distractor points at its height, the room's top) and the
  // outliers that come with them.
  const synth::OrientedBox room = synth::buildSceneLayout(params).room;
  const double height = room.center.z() + room.halfExtents.z();
  const auto atRoof = [&](const Collected& scene) {
    std::size_t count = 0;
    for (std::size_t i = 0; i < scene.positions.size(); ++i) {
      count += scene.labels[i] == 0 && std::abs(scene.positions[i].z() - height) < 5.0 * params.noiseSigma;
    }
    return count;
  };
  const double added = static_cast<double>(roofed.positions.size() - open.positions.size()) -
                       static_cast<double>(roofed.summary.outliers - open.summary.outliers);
  EXPECT_GT(added, 0.2 * static_cast<double>(open.positions.size()));
  EXPECT_NEAR(static_cast<double>(atRoof(roofed) - atRoof(open)), added, 0.01 * added);
}

TEST(GeneratorTest, StationsStandInFreeSpace) {
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    SceneParams params;
    params.seed = seed;
    params.stations = 3;
    const synth::SceneLayout layout = synth::buildSceneLayout(params);
    ASSERT_EQ(layout.stations.size(), 3u);
    const synth::Scanner scanner(layout.surfaces);
    const double floor = layout.room.center.z() - layout.room.halfExtents.z();
    for (const Eigen::Vector3d& station : layout.stations) {
      EXPECT_GE(station.z() - floor, 1.5);
      EXPECT_LE(station.z() - floor, 1.8);
      // No surface within 0.3 m in any direction.
      for (int i = 0; i < 2000; ++i) {
        const double z = -1.0 + 2.0 * (i + 0.5) / 2000.0;
        const double azimuth = i * 2.399963;  // golden angle spiral
        const double ring = std::sqrt(1.0 - z * z);
        const synth::Ray ray{station, Eigen::Vector3d(ring * std::cos(azimuth), ring * std::sin(azimuth), z)};
        EXPECT_FALSE(scanner.castRay(ray, 0.0, 0.3).has_value());
      }
    }
  }
}

TEST(GeneratorTest, StationsAreSetUpWhereThePipingIsSeen) {
  // Scenes where stations put down at random left a rack and its risers without a single point
  // (up to half the piping). The share of pipe length lying on pipes without points stays small:
  // one station cannot see behind everything, two or three see nearly all.
  for (const std::uint64_t seed : {5u, 11u, 12u, 26u, 32u}) {
    SceneParams params;
    params.seed = seed;
    PipeNetwork truth;
    const SceneSummary summary = generateScene(params, truth, [](const PointChunk&) {});
    double total = 0.0, unseen = 0.0;
    for (const Pipe& pipe : truth.pipes) {
      total += pipe.length();
      if (pipe.inlierCount == 0) unseen += pipe.length();
    }
    EXPECT_LT(unseen / total, summary.stations == 1 ? 0.15 : 0.05)
        << "seed " << seed << ", " << summary.stations << " station(s)";
  }
}

TEST(GeneratorTest, PresetNamesRoundTrip) {
  for (const ScenePreset preset : {ScenePreset::Small, ScenePreset::Medium, ScenePreset::Large}) {
    EXPECT_EQ(scenePresetFromString(toString(preset)), preset);
  }
  EXPECT_THROW(scenePresetFromString("huge"), std::invalid_argument);
}

TEST(GeneratorTest, RejectsInvalidParams) {
  const auto invalid = [](const std::function<void(SceneParams&)>& change) {
    SceneParams params;
    change(params);
    PipeNetwork truth;
    EXPECT_THROW(generateScene(params, truth, [](const PointChunk&) {}), std::invalid_argument);
  };
  invalid([](SceneParams& p) { p.stations = 4; });
  invalid([](SceneParams& p) { p.outlierFraction = 1.5; });
  invalid([](SceneParams& p) { p.noiseSigma = -0.001; });
  invalid([](SceneParams& p) { p.densityScale = 0.0; });
  invalid([](SceneParams& p) { p.registrationError = -0.001; });
  invalid([](SceneParams& p) { p.mixedPixelShare = 1.5; });
}

// ---------------------------------------------------------------------------------------------
// The scanner on hand-made scenes.

synth::OrientedBox box(const Eigen::Vector3d& min, const Eigen::Vector3d& max) {
  return synth::OrientedBox{0.5 * (min + max), Eigen::Matrix3d::Identity(), 0.5 * (max - min)};
}

std::vector<synth::ScanStrip> scanAll(const synth::Scanner& scanner, const Eigen::Vector3d& station,
                                      const synth::ScanSettings& settings) {
  std::vector<synth::ScanStrip> strips;
  scanner.scan(station, 0, settings, [&](synth::ScanStrip&& strip, double) { strips.push_back(std::move(strip)); });
  return strips;
}

TEST(GeneratorScannerTest, NearerBoxHidesTheFartherOne) {
  // A small box 3 m in front of the station, a wide one 6 m away behind it.
  const synth::OrientedBox front = box({3.0, -0.5, -0.5}, {3.5, 0.5, 0.5});
  const synth::OrientedBox back = box({6.0, -3.0, -2.0}, {6.5, 3.0, 2.0});
  const synth::Scanner scanner({{front, 1, 0.5f}, {back, 2, 0.5f}});
  synth::ScanSettings settings;
  settings.angularStep = 0.25 * kDegree;
  const Eigen::Vector3d station = Eigen::Vector3d::Zero();
  std::size_t frontPoints = 0, backPoints = 0;
  for (const auto& strip : scanAll(scanner, station, settings)) {
    for (std::size_t i = 0; i < strip.positions.size(); ++i) {
      const Eigen::Vector3d& p = strip.positions[i];
      const double distance = p.norm();
      const synth::Ray ray{station, p / distance};
      if (strip.labels[i] == 2) {
        ++backPoints;
        // Nothing of the front box lies between the station and a point seen on the back box.
        EXPECT_FALSE(synth::intersect(front, ray, 0.0, distance - 1e-6).has_value());
        EXPECT_NEAR(p.x(), 6.0, 1e-9);
      } else {
        ASSERT_EQ(strip.labels[i], 1);
        ++frontPoints;
      }
      // The nearest surface along the ray, found by testing every surface, is the one labelled.
      const auto nearest = scanner.castRay(ray, 0.0, 100.0);
      ASSERT_TRUE(nearest.has_value());
      EXPECT_EQ(scanner.surfaces()[nearest->second].label, strip.labels[i]);
      EXPECT_NEAR(nearest->first.distance, distance, 1e-9);
    }
  }
  EXPECT_GT(frontPoints, 100u);
  EXPECT_GT(backPoints, 1000u);
  // The shadow: no back point straight behind the front box.
  for (const auto& strip : scanAll(scanner, station, settings)) {
    for (std::size_t i = 0; i < strip.positions.size(); ++i) {
      if (strip.labels[i] != 2) continue;
      const Eigen::Vector3d& p = strip.positions[i];
      const bool behindFront = std::abs(p.y() * 3.0 / p.x()) < 0.5 && std::abs(p.z() * 3.0 / p.x()) < 0.5;
      EXPECT_FALSE(behindFront);
    }
  }
}

TEST(GeneratorScannerTest, AcceleratedScanMatchesBruteForce) {
  // Every point of a scan of a generated scene is the nearest hit along its ray over all surfaces.
  SceneParams params;
  params.seed = 11;
  params.stations = 1;
  const synth::SceneLayout layout = synth::buildSceneLayout(params);
  const synth::Scanner scanner(layout.surfaces);
  synth::ScanSettings settings;
  settings.angularStep = 0.6 * kDegree;
  const Eigen::Vector3d station = layout.stations.front();
  std::size_t points = 0;
  for (const auto& strip : scanAll(scanner, station, settings)) {
    for (std::size_t i = 0; i < strip.positions.size(); ++i) {
      const Eigen::Vector3d offset = strip.positions[i] - station;
      const synth::Ray ray{station, offset.normalized()};
      const auto nearest = scanner.castRay(ray, settings.minRange, settings.maxRange);
      ASSERT_TRUE(nearest.has_value());
      EXPECT_EQ(scanner.surfaces()[nearest->second].label, strip.labels[i]);
      EXPECT_NEAR(nearest->first.distance, offset.norm(), 1e-7);
      ++points;
    }
  }
  EXPECT_GT(points, 20000u);
}

TEST(GeneratorScannerTest, LineOfSightMatchesBruteForce) {
  // Rays from a station of a generated scene in many directions, cut short at varied distances:
  // the hierarchy finds a surface across the ray exactly when testing every surface does.
  SceneParams params;
  params.seed = 3;
  const synth::SceneLayout layout = synth::buildSceneLayout(params);
  const synth::Scanner scanner(layout.surfaces);
  const Eigen::Vector3d station = layout.stations.front();
  int blocked = 0, clear = 0;
  for (int i = 0; i < 4000; ++i) {
    const double z = -1.0 + 2.0 * (i + 0.5) / 4000.0;
    const double azimuth = i * 2.399963;  // golden angle spiral
    const double ring = std::sqrt(1.0 - z * z);
    const synth::Ray ray{station, Eigen::Vector3d(ring * std::cos(azimuth), ring * std::sin(azimuth), z)};
    const double reach = 0.5 + 6.0 * ((i * 37) % 100) / 100.0;
    const bool expected = scanner.castRay(ray, 0.3, reach).has_value();
    ASSERT_EQ(scanner.occluded(ray, 0.3, reach), expected) << "ray " << i;
    (expected ? blocked : clear) += 1;
  }
  EXPECT_GT(blocked, 400);
  EXPECT_GT(clear, 400);
}

TEST(GeneratorScannerTest, EveryRayInsideAClosedRoomHitsAWall) {
  // Walls, floor and roof close to the station (inside their bounding spheres) and across the
  // azimuth where the ray grid wraps around: no ray may slip through.
  const synth::Scanner scanner({{box({-3.0, -2.0, -1.6}, {3.0, 2.0, -1.5}), 0, 0.3f},
                                {box({-3.0, -2.0, 2.5}, {3.0, 2.0, 2.6}), 0, 0.3f},
                                {box({-3.1, -2.0, -1.6}, {-3.0, 2.0, 2.6}), 0, 0.3f},
                                {box({3.0, -2.0, -1.6}, {3.1, 2.0, 2.6}), 0, 0.3f},
                                {box({-3.1, -2.1, -1.6}, {3.1, -2.0, 2.6}), 0, 0.3f},
                                {box({-3.1, 2.0, -1.6}, {3.1, 2.1, 2.6}), 0, 0.3f}});
  synth::ScanSettings settings;
  settings.angularStep = 1.0 * kDegree;
  const auto columns = static_cast<std::uint64_t>(std::lround(2.0 * kPi / settings.angularStep));
  const auto rows = static_cast<std::uint64_t>(
      std::floor((settings.maxElevation - settings.minElevation) / settings.angularStep + 1e-9) + 1);
  for (const Eigen::Vector3d& station : {Eigen::Vector3d(0.0, 0.0, 0.0), Eigen::Vector3d(2.5, -1.5, 0.2)}) {
    EXPECT_EQ(scanner.countHits(station, settings), columns * rows);
  }
}

TEST(GeneratorScannerTest, ElbowHitsLieOnTheTorus) {
  // A 90° long-radius elbow of a 10 cm pipe, seen from 3 m away.
  synth::TorusSection elbow;
  elbow.center = Eigen::Vector3d(3.0, 0.0, 0.0);
  elbow.u = Eigen::Vector3d::UnitY();
  elbow.v = Eigen::Vector3d::UnitZ();
  elbow.bendRadius = 0.3;
  elbow.radius = 0.1;
  elbow.sweep = 0.5 * kPi;
  const synth::Scanner scanner({{elbow, 5, 0.8f}});
  synth::ScanSettings settings;
  settings.angularStep = 0.2 * kDegree;
  std::size_t hits = 0;
  for (const auto& strip : scanAll(scanner, Eigen::Vector3d::Zero(), settings)) {
    for (const Eigen::Vector3d& p : strip.positions) {
      const Eigen::Vector3d local = p - elbow.center;
      const double x = local.dot(elbow.u), y = local.dot(elbow.v);
      const double angle = std::atan2(y, x);
      EXPECT_GE(angle, -1e-9);
      EXPECT_LE(angle, elbow.sweep + 1e-9);
      const double inPlane = std::hypot(x, y);
      const double offPlane = local.dot(elbow.u.cross(elbow.v));
      EXPECT_NEAR(std::hypot(inPlane - elbow.bendRadius, offPlane), elbow.radius, 1e-9);
      ++hits;
    }
  }
  EXPECT_GT(hits, 500u);
}

TEST(GeneratorScannerTest, NoiseIsAlongTheNormalWithTheRequestedSigma) {
  // A wall 5 m away: noise moves points off the plane x = 5 with the given standard deviation.
  const synth::Scanner scanner({{box({5.0, -5.0, -3.0}, {5.2, 5.0, 3.0}), 0, 0.5f}});
  synth::ScanSettings settings;
  settings.angularStep = 0.3 * kDegree;
  settings.noiseSigma = 0.002;
  double sum = 0.0, sumSquares = 0.0;
  std::size_t count = 0;
  for (const auto& strip : scanAll(scanner, Eigen::Vector3d::Zero(), settings)) {
    for (const Eigen::Vector3d& p : strip.positions) {
      const double offset = p.x() - 5.0;
      sum += offset;
      sumSquares += offset * offset;
      ++count;
    }
  }
  ASSERT_GT(count, 10000u);
  const double mean = sum / count;
  EXPECT_NEAR(mean, 0.0, 1e-4);
  EXPECT_NEAR(std::sqrt(sumSquares / count - mean * mean), 0.002, 1e-4);
}

TEST(GeneratorScannerTest, DensityFallsWithRange) {
  // Two equal walls at 3 m and 6 m, side by side: the far one gets about a quarter of the points.
  const synth::Scanner scanner(
      {{box({3.0, 0.5, -1.0}, {3.1, 2.5, 1.0}), 1, 0.5f}, {box({6.0, -5.0, -1.0}, {6.1, -3.0, 1.0}), 2, 0.5f}});
  synth::ScanSettings settings;
  settings.angularStep = 0.1 * kDegree;
  std::map<int, double> counts;
  for (const auto& strip : scanAll(scanner, Eigen::Vector3d::Zero(), settings)) {
    for (const std::int32_t label : strip.labels) counts[label] += 1.0;
  }
  ASSERT_GT(counts[2], 100.0);
  // Solid angle of a 2 x 2 m patch: about area · cos(θ) / d².
  const double nearSolidAngle = 4.0 * 3.0 / std::pow(std::hypot(3.0, 1.5), 3.0);
  const double farSolidAngle = 4.0 * 6.0 / std::pow(std::hypot(6.0, 4.0), 3.0);
  EXPECT_NEAR(counts[1] / counts[2], nearSolidAngle / farSolidAngle, 0.15 * nearSolidAngle / farSolidAngle);
}

}  // namespace
}  // namespace piperun
