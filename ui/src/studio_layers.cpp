// Building the studio's layers from the document: points, network, selection, sphere, plane.

#include "studio_impl.h"

#include "mesh.h"
#include "palette.h"

#include <vtkActor.h>
#include <vtkCamera.h>
#include <vtkDoubleArray.h>
#include <vtkLookupTable.h>
#include <vtkNew.h>
#include <vtkPlane.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>
#include <vtkTextProperty.h>

#include <algorithm>
#include <cmath>
#include <utility>

namespace piperun::ui {

vtkSmartPointer<vtkActor> meshActor(vtkPolyData* polyData) {
  auto mapper = vtkSmartPointer<vtkPolyDataMapper>::New();
  mapper->SetInputData(polyData);
  mapper->SetScalarModeToUseCellData();
  mapper->SetColorModeToDirectScalars();
  auto actor = vtkSmartPointer<vtkActor>::New();
  actor->SetMapper(mapper);
  return actor;
}

vtkSmartPointer<vtkTextActor> makeText(double r, double g, double b) {
  auto text = vtkSmartPointer<vtkTextActor>::New();
  text->GetTextProperty()->SetColor(r, g, b);
  text->GetTextProperty()->SetFontFamilyToArial();
  text->GetTextProperty()->ShadowOff();
  return text;
}

// ---------------------------------------------------------------------------------------------
// Layers

void Studio::Impl::setLayer(const std::string& name, vtkRenderer* renderer, vtkSmartPointer<vtkProp> prop,
                            bool defaultVisible) {
  removeLayer(name);
  visibility.emplace(name, defaultVisible);  // Kept when the layer was registered before.
  prop->SetVisibility(visibility[name]);
  renderer->AddViewProp(prop);
  layers[name] = Layer{renderer, std::move(prop)};
}

void Studio::Impl::removeLayer(const std::string& name) {
  const auto found = layers.find(name);
  if (found == layers.end()) return;
  found->second.renderer->RemoveViewProp(found->second.prop);
  layers.erase(found);
  pointLods.erase(name);
  deferredLayers.erase(name);
}

bool Studio::Impl::layerVisible(const std::string& name) const {
  const auto found = visibility.find(name);
  return found != visibility.end() && found->second && layers.count(name);
}

namespace {

/// The first `counts[c]` points of each cell c, as indices into the layer's points.
std::vector<std::uint32_t> firstPointsOfCells(const PointCells& cells, const std::vector<std::uint32_t>& counts) {
  std::vector<std::uint32_t> indices;
  std::size_t total = 0;
  for (const std::uint32_t count : counts) total += count;
  indices.reserve(total);
  for (std::size_t c = 0; c < counts.size(); ++c) {
    const auto first = cells.order.begin() + cells.cells[c].begin;
    indices.insert(indices.end(), first, first + counts[c]);
  }
  return indices;
}

}  // namespace

void Studio::Impl::setPointLayer(const std::string& name, vtkRenderer* renderer, std::vector<Eigen::Vector3f> positions,
                                 std::vector<Rgb> colors, double pointSize, bool defaultVisible,
                                 std::shared_ptr<const PointCloud> source) {
  // The 3-D scene gets the interactive budget; the sphere and plane views, redrawn with it, an eighth each.
  const std::size_t budget =
      std::max<std::size_t>(1, renderer == scene ? options.interactivePoints : options.interactivePoints / 8);
  PointLayerLod lod;
  lod.pointSize = pointSize;
  const std::vector<Eigen::Vector3f>& points = source ? source->positions : positions;
  if (renderer == scene && points.size() > budget) {
    std::shared_ptr<FiledPoints> filed;
    const auto old = pointLods.find(name);
    if (old != pointLods.end() && old->second.filed && old->second.filed->source == source &&
        (source || old->second.filed->positions == positions)) {
      filed = old->second.filed;  // The same points in other colours: filed already.
    } else {
      filed = std::make_shared<FiledPoints>();
      filed->cells = filePointCells(points);
      filed->source = std::move(source);
      filed->positions = std::move(positions);
    }
    filed->colors = std::move(colors);
    // Until the camera's view chooses: the same share of every cell.
    lod.coarse = makePointSet(filed->points(), filed->colors,
                              firstPointsOfCells(filed->cells, pointsToDraw(filed->cells, nullptr, budget)));
    // Over the budget alone: drawn as the subsample until the first still frame chooses its points.
    lod.chosenBudget = filed->points().size() > pointBudget ? pointBudget : 0;
    lod.full = lod.chosenBudget > 0 ? lod.coarse : makePointSet(filed->points(), filed->colors);
    lod.filed = std::move(filed);
  } else {
    lod.full = makePointSet(points, colors);
    const std::size_t stride = std::max<std::size_t>(1, (points.size() + budget - 1) / budget);
    std::vector<std::uint32_t> everyStride;
    for (std::size_t i = 0; stride > 1 && i < points.size(); i += stride)
      everyStride.push_back(static_cast<std::uint32_t>(i));
    lod.coarse = stride > 1 ? makePointSet(points, colors, everyStride) : lod.full;
  }
  lod.mapper = vtkSmartPointer<vtkPolyDataMapper>::New();
  lod.mapper->SetInputData(coarsePoints ? lod.coarse : lod.full);
  lod.mapper->SetScalarModeToUsePointData();
  lod.mapper->SetColorModeToDirectScalars();
  auto actor = vtkSmartPointer<vtkActor>::New();
  actor->SetMapper(lod.mapper);
  actor->GetProperty()->SetPointSize(static_cast<float>(shownPointSize(renderer, pointSize) * options.uiScale));
  actor->GetProperty()->SetColor(kNeutral[0] / 255.0, kNeutral[1] / 255.0, kNeutral[2] / 255.0);
  actor->PickableOff();
  setLayer(name, renderer, actor, defaultVisible);
  pointLods[name] = lod;
}

ViewVolume Studio::Impl::sceneViewVolume(double widening) const {
  vtkNew<vtkCamera> camera;
  camera->DeepCopy(scene->GetActiveCamera());
  camera->SetViewAngle(std::min(widening * camera->GetViewAngle(), kWidestViewAngle));
  camera->SetParallelScale(widening * camera->GetParallelScale());
  double planes[24];
  camera->GetFrustumPlanes(scene->GetTiledAspectRatio(), planes);
  ViewVolume view;
  for (int side = 0; side < 4; ++side) view.planes.emplace_back(Eigen::Map<const Eigen::Vector4d>(planes + 4 * side));
  for (const auto& [normal, offset] : pointClipPlanes())
    view.planes.emplace_back(normal.x(), normal.y(), normal.z(), offset);
  view.eye = Eigen::Vector3d(camera->GetPosition());
  view.perspective = !camera->GetParallelProjection();
  return view;
}

void Studio::Impl::choosePointsInView() {
  if (coarsePoints) return;
  vtkCamera* camera = scene->GetActiveCamera();
  ViewKey key;
  camera->GetPosition(key.data());
  camera->GetFocalPoint(key.data() + 3);
  camera->GetViewUp(key.data() + 6);
  key[9] = camera->GetParallelProjection() ? camera->GetParallelScale() : camera->GetViewAngle();
  key[10] = camera->GetParallelProjection();
  key[11] = scene->GetTiledAspectRatio();
  // The shown layers share the budget in proportion to their points.
  std::size_t shown = 0;
  for (const auto& [name, lod] : pointLods)
    if (lod.filed && layerVisible(name)) shown += lod.filed->points().size();
  std::optional<ViewVolume> view;
  bool changed = false;
  for (auto& [name, lod] : pointLods) {
    if (!lod.filed || !layerVisible(name)) continue;
    const FiledPoints& filed = *lod.filed;
    if (shown <= pointBudget) {
      if (lod.chosenBudget == 0) continue;
      lod.full = makePointSet(filed.points(), filed.colors);  // Every point again.
      lod.chosenBudget = 0;
    } else {
      const auto share = std::max<std::size_t>(
          1, static_cast<std::size_t>(static_cast<double>(pointBudget) * filed.points().size() / shown));
      if (lod.chosenFor == key && lod.chosenBudget == share) continue;
      if (!view) view = sceneViewVolume(1.0);
      lod.full = makePointSet(filed.points(), filed.colors,
                              firstPointsOfCells(filed.cells, pointsToDraw(filed.cells, &*view, share)));
      lod.chosenBudget = share;
    }
    lod.chosenFor = key;
    lod.mapper->SetInputData(lod.full);
    changed = true;
  }
  if (changed) sceneTitle->SetInput(sceneCaption().c_str());
}

std::string Studio::Impl::pointBudgetCaption() const {
  vtkIdType drawn = 0;
  std::size_t total = 0;
  for (const auto& [name, lod] : pointLods) {
    if (lod.chosenBudget == 0 || !layerVisible(name)) continue;
    drawn += lod.full->GetNumberOfPoints();
    total += lod.filed->points().size();
  }
  return total == 0 ? std::string() : "points drawn: " + std::to_string(drawn) + " of " + std::to_string(total);
}

double Studio::Impl::shownPointSize(const vtkRenderer* renderer, double pointSize) const {
  // The scene's layers ask for 2 (input, planes) or 3 (preprocessed) pixels.
  return renderer == scene ? pointSize - 2.0 + scenePointSize : pointSize;
}

void Studio::Impl::setCoarsePoints(bool coarse) {
  if (coarse && !coarsePoints) {
    // What the camera may turn to while it moves: its view widened, the near points densest.
    const ViewVolume view = sceneViewVolume(kMovingViewWidening);
    for (auto& [name, lod] : pointLods) {
      if (!lod.filed || !layerVisible(name)) continue;
      const FiledPoints& filed = *lod.filed;
      lod.coarse = makePointSet(filed.points(), filed.colors,
                                firstPointsOfCells(filed.cells, pointsToDraw(filed.cells, &view,
                                                                             options.interactivePoints)));
    }
  }
  coarsePoints = coarse;
  for (auto& [name, lod] : pointLods) lod.mapper->SetInputData(coarse ? lod.coarse : lod.full);
}

std::vector<Rgb> Studio::Impl::inputPointColors() {
  const PointCloud& cloud = *document.input();
  std::vector<Rgb> colors(cloud.size(), kNeutral);
  switch (pointColor) {
    case PointColor::Height: {
      const auto [low, high] = heightLimits(inputBounds, upAxis());
      auto map = scalarMap(low, high);
      for (std::size_t i = 0; i < cloud.size(); ++i) colors[i] = mapColor(map, heightAlong(upAxis(), cloud.worldPosition(i)));
      break;
    }
    case PointColor::Intensity: {
      auto map = scalarMap(inputIntensities.first, inputIntensities.second);
      for (std::size_t i = 0; i < cloud.size(); ++i) colors[i] = mapColor(map, cloud.intensities[i]);
      break;
    }
    case PointColor::Rgb:
      for (std::size_t i = 0; i < cloud.size(); ++i)
        colors[i] = {cloud.colors[i][0], cloud.colors[i][1], cloud.colors[i][2]};
      break;
    case PointColor::Segment: {
      if (inputToKept.empty())
        inputToKept = nearestKeptPoint(cloud, preprocessed->points, 2.0 * preprocessed->diagnostics.voxelSize + 1e-3);
      if (segmentCache.empty()) segmentCache = keptPointSegments();
      for (std::size_t i = 0; i < cloud.size(); ++i)
        if (inputToKept[i] >= 0) colors[i] = categoryColor(segmentCache[static_cast<std::size_t>(inputToKept[i])]);
      break;
    }
    case PointColor::Element:
    case PointColor::Qa: {
      if (!inputDistances) inputDistances = surfaceDistances(cloud, document.network(), kQaReach);
      auto map = scalarMap(0.0, kQaReach, true);
      for (std::size_t i = 0; i < cloud.size(); ++i)
        colors[i] = pointColor == PointColor::Qa ? mapColor(map, inputDistances->distance[i])
                                                 : categoryColor(inputDistances->element[i]);
      break;
    }
  }
  return colors;
}

void Studio::Impl::buildPointLayers() {
  if (const std::shared_ptr<const PointCloud> input = document.input()) {
    // The display origin is the scan's: its points are drawn where they lie, from its own positions.
    std::vector<Rgb> colors = inputPointColors();
    if (straysHidden) {
      std::vector<Eigen::Vector3f> positions;
      positions.reserve(input->size());
      std::size_t kept = 0;
      for (std::size_t i = 0; i < input->size(); ++i) {
        if (strays[i]) continue;
        positions.push_back(input->positions[i]);
        colors[kept++] = colors[i];
      }
      colors.resize(kept);
      setPointLayer("input/points", scene, std::move(positions), std::move(colors), 2.0, true);
    } else {
      setPointLayer("input/points", scene, {}, std::move(colors), 2.0, true, input);
    }
  } else {
    removeLayer("input/points");
  }

  if (!preprocessed) {
    for (const char* name : {"preprocess/points", "preprocess/normals", "preprocess/planes"}) removeLayer(name);
    applyPointClip();
    return;
  }
  const PointCloud& kept = preprocessed->points;
  if (segmentCache.empty()) segmentCache = keptPointSegments();
  const Eigen::Vector3f shift = (kept.origin - displayOrigin).cast<float>();
  setDeferredPointLayer("preprocess/points", [this] {
    const PointCloud& points = preprocessed->points;
    const Eigen::Vector3f pointShift = (points.origin - displayOrigin).cast<float>();
    std::vector<Eigen::Vector3f> positions(points.size());
    std::vector<Rgb> colors(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
      positions[i] = points.positions[i] + pointShift;
      colors[i] = categoryColor(segmentCache[i]);
    }
    setPointLayer("preprocess/points", scene, std::move(positions), std::move(colors), 3.0, false);
  });

  // Normal glyphs: a short line per point, for a bounded number of points.
  MeshBuilder normals;
  const double length = 3.0 * std::max(preprocessed->diagnostics.voxelSize, 0.005);
  const std::size_t stride = std::max<std::size_t>(1, kept.size() / 40000);
  for (std::size_t i = 0; i < kept.size() && kept.hasNormals(); i += stride) {
    const Eigen::Vector3d from = (kept.positions[i] + shift).cast<double>();
    normals.addPolyline({from, from + length * kept.normals[i].cast<double>()}, categoryColor(segmentCache[i]),
                        static_cast<int>(i));
  }
  auto normalActor = meshActor(normals.build());
  normalActor->PickableOff();
  setLayer("preprocess/normals", scene, normalActor, false);

  setDeferredPointLayer("preprocess/planes", [this] {
    const PointCloud& planes = preprocessed->planePoints;
    std::vector<Eigen::Vector3f> positions(planes.size());
    const Eigen::Vector3f planeShift = (planes.origin - displayOrigin).cast<float>();
    for (std::size_t i = 0; i < planes.size(); ++i) positions[i] = planes.positions[i] + planeShift;
    setPointLayer("preprocess/planes", scene, std::move(positions), std::vector<Rgb>(planes.size(), Rgb{110, 110, 125}),
                  2.0, false);
  });
  applyPointClip();
}

void Studio::Impl::setDeferredPointLayer(const std::string& name, std::function<void()> build) {
  if (visibility.count(name) && visibility[name]) {
    build();
    return;
  }
  setLayer(name, scene, vtkSmartPointer<vtkActor>::New(), false);
  deferredLayers[name] = std::move(build);
}

void Studio::Impl::buildDeferredLayer(const std::string& name) {
  const auto found = deferredLayers.find(name);
  if (found == deferredLayers.end()) return;
  const std::function<void()> build = std::move(found->second);
  deferredLayers.erase(found);
  build();
  applyPointClip();
}

void Studio::Impl::applyPointClip() {
  for (const char* name : {"input/points", "preprocess/points", "preprocess/normals", "preprocess/planes"}) {
    const auto found = layers.find(name);
    auto* actor = found != layers.end() ? vtkActor::SafeDownCast(found->second.prop) : nullptr;
    vtkMapper* mapper = actor ? actor->GetMapper() : nullptr;
    if (!mapper) continue;  // None, or not built yet (setDeferredPointLayer).
    mapper->RemoveAllClippingPlanes();
    for (const auto& [normal, offset] : pointClipPlanes()) {
      vtkNew<vtkPlane> plane;
      plane->SetNormal(normal.data());
      plane->SetOrigin((-offset * normal).eval().data());
      mapper->AddClippingPlane(plane);
    }
  }
  for (auto& [name, lod] : pointLods) lod.chosenFor.reset();  // The clip bounds what a budget is spent on.
}

std::vector<std::pair<Eigen::Vector3d, double>> Studio::Impl::pointClipPlanes() const {
  std::vector<std::pair<Eigen::Vector3d, double>> planes;
  if (!pointClip) return planes;
  for (int axis = 0; axis < 3; ++axis) {
    for (const double side : {-1.0, 1.0}) {
      const double bound = side < 0 ? pointClip->min[axis] : pointClip->max[axis];
      if (!std::isfinite(bound)) continue;
      // Kept: -side * (x - bound) >= 0, x in display co-ordinates.
      const Eigen::Vector3d normal = -side * Eigen::Vector3d::Unit(axis);
      planes.emplace_back(normal, -normal[axis] * (bound - displayOrigin[axis]));
    }
  }
  return planes;
}

void Studio::Impl::buildNetworkLayers() {
  const PipeNetwork& network = document.network();
  double minRadius = 1e9, maxRadius = 0.0;
  for (const auto& pipe : network.pipes) {
    minRadius = std::min(minRadius, pipe.radius);
    maxRadius = std::max(maxRadius, pipe.radius);
  }
  auto radiusMap = scalarMap(minRadius, maxRadius);
  auto confidenceMap = scalarMap(0.0, 1.0);
  // Deleted pipes stay as see-through ghosts, so that they can be selected and restored.
  MeshBuilder pipes, deletedPipes;
  for (const auto& pipe : network.pipes) {
    const std::vector<Eigen::Vector3d> axis{pipe.start - displayOrigin, pipe.end - displayOrigin};
    if (pipe.status == PipeStatus::Deleted) {
      deletedPipes.addTube(axis, pipe.radius, kDeleted, pipe.id);
      continue;
    }
    const Rgb color = pipeColor == PipeColor::Run          ? categoryColor(pipe.runId)
                      : pipeColor == PipeColor::Radius     ? mapColor(radiusMap, pipe.radius)
                      : pipeColor == PipeColor::Confidence ? mapColor(confidenceMap, pipe.confidence)
                                                           : Rgb{185, 190, 200};
    pipes.addTube(axis, pipe.radius, color, pipe.id);
  }
  setLayer("network/pipes", scene, meshActor(pipes.build()), true);
  auto ghosts = meshActor(deletedPipes.build());
  ghosts->GetProperty()->SetOpacity(0.18);
  setLayer("network/deleted-pipes", scene, ghosts, true);

  // Rejected joints are drawn faded: they no longer join anything but can be reconsidered.
  MeshBuilder joints, rejectedJoints;
  for (const auto& joint : network.joints) {
    MeshBuilder& mesh = joint.status == JointStatus::Rejected ? rejectedJoints : joints;
    std::vector<Eigen::Vector3d> axis;
    for (const auto& point : joint.axis) axis.push_back(point - displayOrigin);
    // Slightly fatter than the pipes so the joint's colour shows where they overlap.
    mesh.addTube(axis, joint.radius * 1.06, statusColor(joint.status), joint.id);
    // A tee's branch segment hides inside its main pipe: a collar around the main pipe shows it.
    const Pipe* main =
        joint.type == JointType::Tee && !joint.pipeIds.empty() ? network.findPipe(joint.pipeIds[0]) : nullptr;
    if (main) {
      const Eigen::Vector3d centre = joint.position() - displayOrigin;
      const Eigen::Vector3d along = main->direction() * (1.2 * joint.radius);
      mesh.addTube({centre - along, centre + along}, main->radius * 1.1, statusColor(joint.status), joint.id);
    }
  }
  setLayer("network/joints", scene, meshActor(joints.build()), true);
  auto faded = meshActor(rejectedJoints.build());
  faded->GetProperty()->SetOpacity(0.35);
  setLayer("network/rejected-joints", scene, faded, true);
}

void Studio::Impl::buildSelectionLayer() {
  MeshBuilder highlight;
  const PipeNetwork& network = document.network();
  if (selection.kind == Selection::Kind::Pipe) {
    const Pipe& pipe = *network.findPipe(selection.id);
    highlight.addTube({pipe.start - displayOrigin, pipe.end - displayOrigin}, pipe.radius * 1.12, kHighlight, pipe.id);
    if (const Pipe* second = network.findPipe(selection.secondPipe))
      highlight.addTube({second->start - displayOrigin, second->end - displayOrigin}, second->radius * 1.12, kHighlight,
                        second->id);
  } else if (selection.kind == Selection::Kind::Joint) {
    const Joint& joint = *network.findJoint(selection.id);
    std::vector<Eigen::Vector3d> axis;
    for (const auto& point : joint.axis) axis.push_back(point - displayOrigin);
    highlight.addTube(axis, joint.radius * 1.18, kHighlight, joint.id);
  }
  auto actor = meshActor(highlight.build());
  actor->PickableOff();
  // Drawn over the scene (its own layer, same camera) so a selection inside other pipes shows.
  setLayer("selection/highlight", highlightLayer, actor, true);
  placeEndHandle();
}

void Studio::Impl::buildSphereLayers() {
  // Reference grid: the equator and meridians of the unit sphere.
  MeshBuilder grid;
  const Rgb gridColor{70, 75, 85};
  for (int latitude = -60; latitude <= 60; latitude += 30) {
    const double z = std::sin(latitude * M_PI / 180.0), r = std::cos(latitude * M_PI / 180.0);
    grid.addPolyline(circlePoints({0, 0, z}, Eigen::Vector3d::UnitZ(), r), gridColor, -1, true);
  }
  for (int longitude = 0; longitude < 180; longitude += 30) {
    const double angle = longitude * M_PI / 180.0;
    grid.addPolyline(circlePoints(Eigen::Vector3d::Zero(), {std::cos(angle), std::sin(angle), 0.0}, 1.0), gridColor, -1,
                     true);
  }
  auto gridActor = meshActor(grid.build());
  gridActor->PickableOff();
  setLayer("sphere/grid", sphere, gridActor, true);

  if (!preprocessed || !tiles) {
    for (const char* name : {"sphere/normals", "sphere/density", "sphere/directions", "preprocess/tile"})
      removeLayer(name);
    return;
  }
  // Normals at both their signs (the sign is arbitrary), coloured by segment: on a tiled scan, the
  // Gaussian sphere of one tile (the selected direction's), as the method analyses it.
  const PointCloud& kept = preprocessed->points;
  const int shownTile = sphereTile();
  if (segmentCache.empty()) segmentCache = keptPointSegments();
  const Tile* tileShown = sphereTilePoints();
  std::vector<int> tileSegments;
  if (shownTile >= 0) {
    // Overlapping tiles label the same points: colour them by this tile's own directions.
    tileSegments.assign(kept.size(), -1);
    for (std::size_t k = 0; k < directions.size(); ++k)
      if (directions[k].tile == shownTile)
        for (std::uint32_t point : direction(directions[k]).stripe)
          if (point < tileSegments.size()) tileSegments[point] = static_cast<int>(k);
  }
  const std::size_t shownCount = shownTile < 0 ? kept.size() : tileShown ? tileShown->points.size() : 0;
  std::vector<Eigen::Vector3f> normalPoints;
  std::vector<Rgb> normalColors;
  const std::size_t stride = std::max<std::size_t>(1, shownCount / 30000);
  for (std::size_t n = 0; n < shownCount && kept.hasNormals(); n += stride) {
    const std::size_t i = shownTile >= 0 ? tileShown->points[n] : n;
    const Rgb color = categoryColor(shownTile >= 0 ? tileSegments[i] : segmentCache[i]);
    normalPoints.push_back(kept.normals[i]);
    normalPoints.push_back(-kept.normals[i]);
    normalColors.insert(normalColors.end(), {color, color});
  }
  setPointLayer("sphere/normals", sphere, std::move(normalPoints), std::move(normalColors), 1.0, true);

  // Direction samples (n_i × n_j) coloured by their density: counts in equal-area cells of the
  // upper hemisphere (uniform in z and in longitude).
  constexpr int kZCells = 40, kLongitudeCells = 120;
  std::vector<Eigen::Vector3f> samples;
  for (std::size_t t = 0; t < tiles->size(); ++t)
    if (shownTile < 0 || static_cast<int>(t) == shownTile)
      for (std::size_t r = 0; r < (*tiles)[t].rounds.size(); ++r) {
        const auto& drawn = viewRound(static_cast<int>(t), static_cast<int>(r)).directions.samples;
        samples.insert(samples.end(), drawn.begin(), drawn.end());
      }
  auto cellOf = [&](const Eigen::Vector3f& s) {
    const int zCell = std::clamp(static_cast<int>(s.z() * kZCells), 0, kZCells - 1);
    const double longitude = std::atan2(s.y(), s.x()) + M_PI;
    const int longitudeCell =
        std::clamp(static_cast<int>(longitude / (2.0 * M_PI) * kLongitudeCells), 0, kLongitudeCells - 1);
    return zCell * kLongitudeCells + longitudeCell;
  };
  std::vector<int> counts(kZCells * kLongitudeCells, 0);
  for (const auto& s : samples) ++counts[static_cast<std::size_t>(cellOf(s))];
  const int peak = std::max(1, *std::max_element(counts.begin(), counts.end()));
  auto densityMap = scalarMap(0.0, std::log1p(static_cast<double>(peak)));
  std::vector<Eigen::Vector3f> densityPoints;
  std::vector<Rgb> densityColors;
  const std::size_t sampleStride = std::max<std::size_t>(1, samples.size() / 40000);
  for (std::size_t i = 0; i < samples.size(); i += sampleStride) {
    densityPoints.push_back(samples[i] * 1.015f);
    densityColors.push_back(
        mapColor(densityMap, std::log1p(static_cast<double>(counts[static_cast<std::size_t>(cellOf(samples[i]))]))));
  }
  setPointLayer("sphere/density", sphere, std::move(densityPoints), std::move(densityColors), 2.0, true);

  // Principal directions: arrows with their great circles (where the stripe's normals lie).
  MeshBuilder arrows;
  for (std::size_t k = 0; k < directions.size(); ++k) {
    if (shownTile >= 0 && directions[k].tile != shownTile) continue;
    const bool selected = static_cast<int>(k) == selectedDirection;
    const Rgb color = selected ? kHighlight : categoryColor(static_cast<int>(k));
    const Eigen::Vector3d axis = direction(directions[k]).axis;
    arrows.addArrow(Eigen::Vector3d::Zero(), axis, 1.3, selected ? 0.022 : 0.013, color, static_cast<int>(k));
    arrows.addPolyline(circlePoints(Eigen::Vector3d::Zero(), axis, 1.005), color, static_cast<int>(k), true);
  }
  auto arrowActor = meshActor(arrows.build());
  arrowActor->GetProperty()->SetLineWidth(static_cast<float>(2.0 * options.uiScale));
  setLayer("sphere/directions", sphere, arrowActor, true);

  // Where that tile is in the 3-D scene.
  const auto tileCube = sphereTileCube();
  if (!tileCube) {
    removeLayer("preprocess/tile");
    return;
  }
  MeshBuilder cube;
  const Eigen::Vector3d low = tileCube->min - displayOrigin, high = tileCube->max - displayOrigin;
  auto corner = [&](int bits) {
    return Eigen::Vector3d((bits & 1) ? high.x() : low.x(), (bits & 2) ? high.y() : low.y(), (bits & 4) ? high.z() : low.z());
  };
  for (int bits = 0; bits < 8; ++bits)
    for (int axis = 0; axis < 3; ++axis)
      if (!(bits & (1 << axis))) cube.addPolyline({corner(bits), corner(bits | (1 << axis))}, kTileBox, -1);
  auto cubeActor = meshActor(cube.build());
  cubeActor->PickableOff();
  cubeActor->GetProperty()->SetLineWidth(static_cast<float>(1.5 * options.uiScale));
  setLayer("preprocess/tile", scene, cubeActor, true);
  showSphereTileBox();
}

void Studio::Impl::showSphereTileBox() {
  const auto found = layers.find("preprocess/tile");
  if (found != layers.end()) found->second.prop->SetVisibility(visibility["preprocess/tile"] && viewMode == ViewMode::All);
}

void Studio::Impl::buildPlaneLayers() {
  if (!preprocessed || !tiles || selectedDirection < 0) {
    for (const char* name : {"plane/points", "plane/candidates", "plane/circles"}) removeLayer(name);
    return;
  }
  const DirectionRef& ref = directions[static_cast<std::size_t>(selectedDirection)];
  const PrincipalDirection& chosen = direction(ref);
  const PlacementResult* placement = &viewRound(ref.tile, ref.round).placement;  // with its candidates
  const PointCloud& kept = preprocessed->points;

  std::vector<Eigen::Vector3f> projected;
  std::vector<Rgb> pointColors;
  const PlacementResult::Projection* projection = ref.index < static_cast<int>(placement->projections.size())
                                                      ? &placement->projections[static_cast<std::size_t>(ref.index)]
                                                      : nullptr;
  Eigen::Vector3d u, v;
  if (projection) {
    u = projection->u;
    v = projection->v;
  } else {
    orthonormalBasis(chosen.axis, u, v);
  }
  for (std::uint32_t point : chosen.stripe) {
    const Eigen::Vector3d p = kept.positions[point].cast<double>();
    projected.emplace_back(static_cast<float>(p.dot(u)), static_cast<float>(p.dot(v)), 0.0f);
    pointColors.push_back({175, 175, 185});
  }
  setPointLayer("plane/points", plane, std::move(projected), std::move(pointColors), 2.0, true);

  std::vector<Eigen::Vector3f> candidates;
  std::vector<Rgb> candidateColors;
  if (projection)
    for (const auto& candidate : projection->candidates) {
      candidates.emplace_back(candidate.center.x(), candidate.center.y(), 0.001f);
      candidateColors.push_back(candidate.circle >= 0 ? categoryColor(candidate.circle) : Rgb{95, 95, 110});
    }
  setPointLayer("plane/candidates", plane, std::move(candidates), std::move(candidateColors), 3.0, true);

  MeshBuilder circles;
  for (std::size_t c = 0; c < placement->cylinders.size(); ++c) {
    const Cylinder& cylinder = placement->cylinders[c];
    if (cylinder.directionIndex != ref.index) continue;
    const Eigen::Vector3d center(cylinder.point.dot(u), cylinder.point.dot(v), 0.002);
    const bool selected =
        selection.kind == Selection::Kind::Pipe && pipeOfCylinder(ref, static_cast<int>(c)) == selection.id;
    circles.addPolyline(circlePoints(center, Eigen::Vector3d::UnitZ(), cylinder.radius),
                        selected ? kHighlight : Rgb{255, 60, 60}, static_cast<int>(c), true);
  }
  auto circleActor = meshActor(circles.build());
  circleActor->GetProperty()->SetLineWidth(static_cast<float>(2.5 * options.uiScale));
  setLayer("plane/circles", plane, circleActor, true);
}

void Studio::Impl::updateColorBar() {
  vtkSmartPointer<vtkLookupTable> map;
  std::string title;
  if (layerVisible("input/points") && document.input()) {
    if (pointColor == PointColor::Height) {
      const auto [low, high] = heightLimits(inputBounds, upAxis());
      map = scalarMap(low, high);
      title = "height (m)";
    } else if (pointColor == PointColor::Intensity) {
      map = scalarMap(inputIntensities.first, inputIntensities.second);
      title = "intensity";
    } else if (pointColor == PointColor::Qa) {
      map = scalarMap(0.0, kQaReach, true);
      title = "QA distance (m)";
    }
  }
  if (!map && layerVisible("network/pipes") && !document.network().pipes.empty() &&
      (pipeColor == PipeColor::Radius || pipeColor == PipeColor::Confidence)) {
    const auto& pipes = document.network().pipes;
    if (pipeColor == PipeColor::Radius) {
      const auto [low, high] = std::minmax_element(pipes.begin(), pipes.end(),
                                                   [](const Pipe& a, const Pipe& b) { return a.radius < b.radius; });
      map = scalarMap(low->radius, high->radius);
      title = "pipe radius (m)";
    } else {
      map = scalarMap(0.0, 1.0);
      title = "pipe confidence";
    }
  }
  const bool sceneShown = viewMode == ViewMode::All || viewMode == ViewMode::Scene;
  colorBar->SetVisibility(map != nullptr && sceneShown);
  if (map) {
    colorBar->SetLookupTable(map);
    colorBar->SetTitle(title.c_str());
    const double* range = map->GetRange();
    vtkNew<vtkDoubleArray> labels;
    for (const double tick : roundTicks(range[0], range[1], kColorBarLabels)) labels->InsertNextValue(tick);
    colorBar->SetCustomLabels(labels);
    colorBar->UseCustomLabelsOn();
  }
}

}  // namespace piperun::ui
