#include "piperun/pipe_measures.h"

#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <vector>

namespace piperun {
namespace {

Pipe pipeBetween(const Eigen::Vector3d& start, const Eigen::Vector3d& end, double radius) {
  Pipe pipe;
  pipe.start = start;
  pipe.end = end;
  pipe.radius = radius;
  return pipe;
}

TEST(PipeMeasures, APipeLiesAtTheHeightsOfItsEndsAlongTheUpAxisWithItsSlope) {
  // 10 m run falling 0.2 m: a 2 % slope (1.146°), whichever end comes first.
  const Pipe run = pipeBetween({0, 0, 3.2}, {10, 0, 3.0}, 0.05);
  const PipeLie lie = pipeLie(run, UpAxis::PlusZ);
  EXPECT_DOUBLE_EQ(lie.lowHeight, 3.0);
  EXPECT_DOUBLE_EQ(lie.highHeight, 3.2);
  EXPECT_NEAR(lie.slopeDegrees, std::atan(0.02) * 45.0 / std::atan(1.0), 1e-6);
  EXPECT_NEAR(lie.slopePercent(), 2.0, 1e-6);

  // The same pipe turned so that y is up, and told so; with −z up its heights are negated.
  const PipeLie turned = pipeLie(pipeBetween({0, 3.2, 0}, {10, 3.0, 0}, 0.05), UpAxis::PlusY);
  EXPECT_DOUBLE_EQ(turned.lowHeight, 3.0);
  EXPECT_DOUBLE_EQ(turned.highHeight, 3.2);
  EXPECT_NEAR(turned.slopeDegrees, lie.slopeDegrees, 1e-12);
  const PipeLie upsideDown = pipeLie(run, UpAxis::MinusZ);
  EXPECT_DOUBLE_EQ(upsideDown.lowHeight, -3.2);
  EXPECT_DOUBLE_EQ(upsideDown.highHeight, -3.0);

  const PipeLie riser = pipeLie(pipeBetween({1, 1, 0.5}, {1, 1, 4.0}, 0.1), UpAxis::PlusZ);
  EXPECT_DOUBLE_EQ(riser.slopeDegrees, 90.0);
  EXPECT_DOUBLE_EQ(riser.lowHeight, 0.5);
  EXPECT_DOUBLE_EQ(riser.highHeight, 4.0);
  EXPECT_DOUBLE_EQ(pipeLie(pipeBetween({0, 0, 1}, {5, 5, 1}, 0.1), UpAxis::PlusZ).slopeDegrees, 0.0);
}

TEST(PipeMeasures, ATubeReachesItsBottomAndTopOfPipeWhenLevelAndItsEndFacesWhenPlumb) {
  const double r = 0.1;
  const TubeHeights level = tubeHeights({{0, 0, 3}, {6, 0, 3}}, r, UpAxis::PlusZ);
  EXPECT_DOUBLE_EQ(level.lowest, 3 - r);
  EXPECT_DOUBLE_EQ(level.highest, 3 + r);
  const TubeHeights riser = tubeHeights({{1, 1, 0.5}, {1, 1, 4.0}}, r, UpAxis::PlusZ);
  EXPECT_DOUBLE_EQ(riser.lowest, 0.5);
  EXPECT_DOUBLE_EQ(riser.highest, 4.0);
  // At 45° an end circle reaches r cos 45° above and below its centre.
  const TubeHeights leaning = tubeHeights({{0, 0, 1}, {1, 0, 2}}, r, UpAxis::PlusZ);
  EXPECT_NEAR(leaning.lowest, 1 - r * std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(leaning.highest, 2 + r * std::sqrt(0.5), 1e-12);
  // A bend from level to plumb: the level leg's bottom, the plumb leg's top end.
  const TubeHeights bend = tubeHeights({{0, 0, 0}, {1, 0, 0}, {1, 0, 1}}, r, UpAxis::PlusZ);
  EXPECT_DOUBLE_EQ(bend.lowest, -r);
  EXPECT_DOUBLE_EQ(bend.highest, 1.0);
  // Along y up, the level pipe turned.
  const TubeHeights turned = tubeHeights({{0, 3, 0}, {6, 3, 0}}, r, UpAxis::PlusY);
  EXPECT_DOUBLE_EQ(turned.lowest, 3 - r);
  EXPECT_DOUBLE_EQ(turned.highest, 3 + r);
}

TEST(PipeMeasures, AnElbowsBendIsTheCircleThroughItsArcAndNamesItsFitting) {
  // A 45° arc of radius 0.3 about (1, 2, 3), turning about +z.
  const Eigen::Vector3d centre(1, 2, 3);
  const double radius = 0.3, angle = std::atan(1.0);
  const auto arc = sampleArc(centre, centre + Eigen::Vector3d(radius, 0, 0),
                             centre + radius * Eigen::Vector3d(std::cos(angle), std::sin(angle), 0), 0.01);
  const std::optional<Bend> bend = bendOf(arc);
  ASSERT_TRUE(bend);
  EXPECT_NEAR((bend->centre - centre).norm(), 0.0, 1e-9);
  EXPECT_NEAR(bend->radius, radius, 1e-9);
  EXPECT_NEAR(bend->angleDegrees(), 45.0, 1e-6);
  EXPECT_NEAR(bend->axis.z(), 1.0, 1e-9);
  EXPECT_EQ(elbowAngleOf(bend->angleDegrees()), ElbowAngle::FortyFive);
  // Turning the other way, the axis turns over and the angle stays.
  const std::optional<Bend> back = bendOf(std::vector<Eigen::Vector3d>(arc.rbegin(), arc.rend()));
  ASSERT_TRUE(back);
  EXPECT_NEAR(back->angleDegrees(), 45.0, 1e-6);
  EXPECT_NEAR(back->axis.z(), -1.0, 1e-9);
  // Straight or too short: no bend.
  EXPECT_FALSE(bendOf({{0, 0, 0}, {0.5, 0, 0}, {1, 0, 0}}));
  EXPECT_FALSE(bendOf({{0, 0, 0}, {1, 0, 0}}));
  // Fittings: 90° and 45° within 7.5°.
  EXPECT_EQ(elbowAngleOf(88.9), ElbowAngle::Ninety);
  EXPECT_EQ(elbowAngleOf(97.5), ElbowAngle::Ninety);
  EXPECT_EQ(elbowAngleOf(37.7), ElbowAngle::FortyFive);
  EXPECT_EQ(elbowAngleOf(60.0), ElbowAngle::Other);
  EXPECT_EQ(elbowAngleOf(180.0), ElbowAngle::Other);
}

TEST(PipeMeasures, TwoPipesAreApartByTheirAxesNearestDistanceLessTheirRadii) {
  // Two parallel rack pipes 0.4 m apart between centres: 0.25 m between their surfaces.
  const Pipe a = pipeBetween({0, 0, 3}, {6, 0, 3}, 0.1);
  const Pipe b = pipeBetween({1, 0.4, 3}, {5, 0.4, 3}, 0.05);
  const PipesApart parallel = pipesApart(a, b);
  EXPECT_NEAR(parallel.axisDistance, 0.4, 1e-12);
  EXPECT_NEAR(parallel.clearance, 0.25, 1e-12);
  EXPECT_NEAR(parallel.angleDegrees, 0.0, 1e-6);

  // A pipe crossing under at 90°, its axis 0.12 m below: the tubes overlap by 0.03 m.
  const PipesApart crossing = pipesApart(a, pipeBetween({3, -2, 2.88}, {3, 2, 2.88}, 0.05));
  EXPECT_NEAR(crossing.axisDistance, 0.12, 1e-12);
  EXPECT_NEAR(crossing.clearance, -0.03, 1e-12);
  EXPECT_NEAR(crossing.angleDegrees, 90.0, 1e-9);

  // Past the end: the nearest distance is the segments', not the lines' (a's end (6, 0) to (8, 2),
  // halfway along b); the angle is the lines' whichever way the pipes run.
  const PipesApart beyond = pipesApart(a, pipeBetween({9, 1, 3}, {7, 3, 3}, 0.05));
  EXPECT_NEAR(beyond.axisDistance, 2.0 * std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(beyond.angleDegrees, 45.0, 1e-9);
}

}  // namespace
}  // namespace piperun
