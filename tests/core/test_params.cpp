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
  b.extents.minArcDeg += 10;
  EXPECT_EQ(firstChangedStage(a, b), Stage::Extents);
  b.placement.minInliers += 1;
  EXPECT_EQ(firstChangedStage(a, b), Stage::Placement);
  b.seed += 1;
  EXPECT_EQ(firstChangedStage(a, b), Stage::Directions);
  b.preprocess.tileSize += 1;
  EXPECT_EQ(firstChangedStage(a, b), Stage::Preprocess);
}

}  // namespace
}  // namespace piperun
