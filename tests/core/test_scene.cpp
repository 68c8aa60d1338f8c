#include "test_scene.h"

namespace piperun::test {

const GeneratedScene& smallScene() {
  static const GeneratedScene generated = [] {
    SceneParams params;
    params.seed = 11;
    params.densityScale = 0.5;
    return generateScene(params);
  }();
  return generated;
}

std::shared_ptr<const PointCloud> smallSceneCloud() {
  static const auto cloud = std::make_shared<const PointCloud>(smallScene().cloud.clone());
  return cloud;
}

}  // namespace piperun::test
