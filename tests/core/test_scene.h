#pragma once
// One small generated scene (seed 11, half density) shared by the tests that run the pipeline:
// generating it costs more than a test should, so it is made once per test process.

#include "piperun/point_cloud.h"
#include "piperun/synth/scene_generator.h"

#include <memory>

namespace piperun::test {

const GeneratedScene& smallScene();
std::shared_ptr<const PointCloud> smallSceneCloud();

}  // namespace piperun::test
