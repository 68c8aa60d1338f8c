#include "piperun/error.h"
#include "piperun/params.h"

#include <gtest/gtest.h>

#include <set>

namespace piperun {
namespace {

TEST(Params, JsonRoundTripKeepsEveryValue) {
  PipelineParams params;
  params.seed = 42;
  params.rounds = 3;
  params.preprocess.voxelSize = 0.02;
  params.preprocess.removePlanes = false;
  params.placement.maxRadius = 0.5;
  params.merge.maxGap = 0.1;
  const PipelineParams back = paramsFromJson(paramsToJson(params), "p.json");
  EXPECT_EQ(paramsToJson(back), paramsToJson(params));
  EXPECT_EQ(back.seed, 42u);
  EXPECT_FALSE(back.preprocess.removePlanes);
  EXPECT_EQ(back.placement.maxRadius, 0.5);
}

TEST(Params, PartialDocumentKeepsTheOtherDefaults) {
  const PipelineParams params = paramsFromJson(R"({"placement": {"max_radius": 0.4}, "seed": 7})", "p.json");
  EXPECT_EQ(params.placement.maxRadius, 0.4);
  EXPECT_EQ(params.seed, 7u);
  EXPECT_EQ(params.placement.minRadius, PipelineParams{}.placement.minRadius);
}

TEST(Params, UnknownKeysAndWrongTypesNameTheKey) {
  try {
    paramsFromJson(R"({"placement": {"max_radios": 0.4}})", "p.json");
    FAIL();
  } catch (const InputError& error) {
    EXPECT_EQ(error.location(), "/placement/max_radios");
  }
  try {
    paramsFromJson(R"({"preprocess": {"remove_planes": 1}})", "p.json");
    FAIL();
  } catch (const InputError& error) {
    EXPECT_EQ(error.location(), "/preprocess/remove_planes");
    EXPECT_NE(std::string(error.what()).find("true or false"), std::string::npos);
  }
  EXPECT_THROW(paramsFromJson("{", "p.json"), InputError);
}

TEST(Params, AssignmentsFromTheCommandLine) {
  PipelineParams params;
  setParam(params, "placement.center_bandwidth=0.02");
  setParam(params, "preprocess.remove_planes=false");
  setParam(params, "rounds=1");
  EXPECT_EQ(params.placement.centerBandwidth, 0.02);
  EXPECT_FALSE(params.preprocess.removePlanes);
  EXPECT_EQ(params.rounds, 1);
  EXPECT_THROW(setParam(params, "placement.nothing=1"), std::invalid_argument);
  EXPECT_THROW(setParam(params, "rounds=two"), std::invalid_argument);
  EXPECT_THROW(setParam(params, "rounds"), std::invalid_argument);
}

TEST(Params, TheUpAxisIsAnAxisNameOnTheCommandLineAndInDocuments) {
  PipelineParams params;
  EXPECT_EQ(params.up, UpAxis::PlusZ);
  setParam(params, "up=y");
  EXPECT_EQ(params.up, UpAxis::PlusY);
  setParam(params, "up=\"-x\"");
  EXPECT_EQ(params.up, UpAxis::MinusX);
  setParam(params, "up=+z");
  EXPECT_EQ(params.up, UpAxis::PlusZ);
  for (const char* wrong : {"up=w", "up=1", "up=", "up=true"}) {
    try {
      setParam(params, wrong);
      FAIL() << wrong;
    } catch (const std::invalid_argument& error) {
      EXPECT_NE(std::string(error.what()).find("one of \"x\", \"y\", \"z\", \"-x\", \"-y\", \"-z\""), std::string::npos)
          << error.what();
    }
  }
  EXPECT_EQ(params.up, UpAxis::PlusZ);

  params.up = UpAxis::MinusY;
  const std::string document = paramsToJson(params);
  EXPECT_NE(document.find("\"up\": \"-y\""), std::string::npos) << document;
  EXPECT_EQ(paramsFromJson(document, "p.json").up, UpAxis::MinusY);
  try {
    paramsFromJson(R"({"up": 2})", "p.json");
    FAIL();
  } catch (const InputError& error) {
    EXPECT_EQ(error.location(), "/up");
  }
  EXPECT_THROW(paramsFromJson(R"({"up": "north"})", "p.json"), InputError);
}

TEST(Params, ValuesOutsideTheirRangeAreRefusedNamingTheKeyAndTheRange) {
  PipelineParams params;
  const auto refusal = [&](const std::string& assignment) -> std::string {
    try {
      setParam(params, assignment);
    } catch (const std::invalid_argument& error) {
      return error.what();
    }
    return "";
  };
  EXPECT_EQ(refusal("placement.center_bandwidth=0"), "parameter placement.center_bandwidth must be > 0 m, not 0");
  EXPECT_EQ(params.placement.centerBandwidth, PipelineParams{}.placement.centerBandwidth);  // left as it was
  EXPECT_EQ(refusal("directions.min_support=1.5"), "parameter directions.min_support must lie in [0, 1], not 1.5");
  EXPECT_EQ(refusal("rounds=0"), "parameter rounds must be >= 1, not 0");
  // Tiles of a few centimetres would run the per-tile stages practically forever.
  EXPECT_NE(refusal("preprocess.tile_size=0.01").find(">= 0.5 m"), std::string::npos);
  // Each end of a range is open or closed as documented.
  EXPECT_EQ(refusal("directions.min_pair_angle_deg=0"), "");
  EXPECT_NE(refusal("directions.min_pair_angle_deg=90"), "");
  EXPECT_EQ(refusal("directions.bandwidth_deg=30"), "");
  EXPECT_NE(refusal("directions.bandwidth_deg=0"), "");
  // A number no double holds is no number.
  EXPECT_NE(refusal("placement.min_radius=1e999").find("is not a number"), std::string::npos);
  EXPECT_EQ(refusal("joints.accept_confidence=1.01"), "");  // every joint proposed, for review
}

TEST(Params, DocumentValuesOutsideTheirRangeNameTheirPlace) {
  try {
    paramsFromJson(R"({"placement": {"center_bandwidth": -0.01}})", "p.json");
    FAIL();
  } catch (const InputError& error) {
    EXPECT_EQ(error.location(), "/placement/center_bandwidth");
    EXPECT_NE(std::string(error.what()).find("must be > 0 m"), std::string::npos) << error.what();
  }
  EXPECT_THROW(paramsFromJson(R"({"placement": {"min_radius": 1e999}})", "p.json"), InputError);
}

TEST(Params, BoundsThatDependOnEachOtherAreCheckedTogether) {
  EXPECT_NO_THROW(validateParams(PipelineParams{}));
  PipelineParams params;
  params.placement.minRadius = 0.5;
  params.preprocess.tileOverlap = params.preprocess.tileSize;
  params.joints.minBendRadii = 6.0;
  params.joints.minElbowAngleDeg = params.joints.maxElbowAngleDeg;
  params.extents.minArcDeg = -1.0;
  try {
    validateParams(params);
    FAIL();
  } catch (const std::invalid_argument& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("placement.min_radius (0.5) must be below placement.max_radius (0.35)"), std::string::npos);
    EXPECT_NE(message.find("preprocess.tile_overlap (5) must be below preprocess.tile_size (5)"), std::string::npos);
    EXPECT_NE(message.find("joints.min_bend_radii (6) must be at most joints.max_bend_radii (5)"), std::string::npos);
    EXPECT_NE(message.find("joints.min_elbow_angle_deg (135) must be below"), std::string::npos);
    EXPECT_NE(message.find("extents.min_arc_deg must lie in [0, 360] deg, not -1"), std::string::npos) << message;
  }
}

TEST(Params, EveryNumberHasARangeAndEveryDefaultLiesInIt) {
  for (const auto& p : describeParams()) {
    const bool flag = p.defaultValue == "true" || p.defaultValue == "false";
    const bool word = p.defaultValue.front() == '"';
    // The seed takes any value; every other number is bounded somewhere.
    EXPECT_EQ(p.range.empty(), flag || word || p.key == "seed") << p.key;
  }
  EXPECT_NO_THROW(validateParams(PipelineParams{}));
}

TEST(Params, EveryParameterIsDescribedOnce) {
  std::set<std::string> keys;
  for (const auto& p : describeParams()) {
    EXPECT_TRUE(keys.insert(p.key).second) << p.key;
    EXPECT_FALSE(p.description.empty()) << p.key;
    EXPECT_FALSE(p.defaultValue.empty()) << p.key;
  }
  EXPECT_GT(keys.size(), 30u);
}

TEST(Params, FirstChangedStage) {
  PipelineParams a;
  PipelineParams b = a;
  EXPECT_FALSE(firstChangedStage(a, b));
  b.preprocess.keptNeighborsMB = 0;  // the same normals, searched again: no result changes
  EXPECT_FALSE(firstChangedStage(a, b));
  b.extents.minArcDeg += 10;
  EXPECT_EQ(firstChangedStage(a, b), Stage::Extents);
  PipelineParams turned = a;
  turned.up = UpAxis::PlusY;  // Read by the joints stage alone.
  EXPECT_EQ(firstChangedStage(a, turned), Stage::Joints);
  b.placement.minInliers += 1;
  EXPECT_EQ(firstChangedStage(a, b), Stage::Placement);
  b.seed += 1;
  EXPECT_EQ(firstChangedStage(a, b), Stage::Directions);
  b.preprocess.tileSize += 1;
  EXPECT_EQ(firstChangedStage(a, b), Stage::Preprocess);
}

}  // namespace
}  // namespace piperun
