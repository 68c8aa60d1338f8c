#include "studio_impl.h"

#include "mesh.h"
#include "observe.h"
#include "palette.h"

#include "piperun/edit/review_queue.h"
#include "piperun/error.h"
#include "piperun/pipe_measures.h"

#include <nlohmann/json.hpp>

#include <vtkBoxRepresentation.h>
#include <vtkCallbackCommand.h>
#include <vtkCamera.h>
#include <vtkCellData.h>
#include <vtkCellPicker.h>
#include <vtkIntArray.h>
#include <vtkObjectFactory.h>
#include <vtkPointHandleRepresentation3D.h>
#include <vtkPolyData.h>
#include <vtkProperty.h>
#include <vtkRenderWindow.h>
#include <vtkRenderWindowInteractor.h>
#include <vtkTextProperty.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>

namespace piperun::ui {

vtkStandardNewMacro(StudioInteractorStyle);

void StudioInteractorStyle::OnLeftButtonDown() {
  const int* position = this->Interactor->GetEventPosition();
  this->FindPokedRenderer(position[0], position[1]);
  if (this->CurrentRenderer && this->CurrentRenderer == panOnly) {
    this->GrabFocus(this->EventCallbackCommand);
    this->StartPan();
    return;
  }
  vtkInteractorStyleTrackballCamera::OnLeftButtonDown();
}

namespace {

/// The value of "section.key" in the parameters.
double parameterValue(const PipelineParams& params, const std::string& key) {
  const nlohmann::json document = nlohmann::json::parse(paramsToJson(params));
  const std::size_t dot = key.find('.');
  const nlohmann::json& value = document.at(key.substr(0, dot)).at(key.substr(dot + 1));
  return value.is_boolean() ? (value.get<bool>() ? 1.0 : 0.0) : value.get<double>();
}

/// `text` with each line longer than `columns` characters broken at blanks into lines of at most
/// that many (a longer word keeps a line of its own); the blanks at a break go, the others stay. A
/// break goes between fields, which the info text spaces by two blanks, where one fits.
std::string wrapLines(const std::string& text, std::size_t columns) {
  std::string wrapped;
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    if (!wrapped.empty()) wrapped += '\n';
    while (line.size() > columns) {
      const std::size_t first = line.find_first_not_of(' ');
      const auto within = [&](std::size_t cut) {
        return cut != std::string::npos && first != std::string::npos && cut > first;
      };
      std::size_t cut = line.rfind("  ", columns);
      if (!within(cut)) cut = line.rfind(' ', columns);
      if (!within(cut)) cut = line.find(' ', columns);
      if (cut == std::string::npos) break;
      wrapped += line.substr(0, line.find_last_not_of(' ', cut) + 1) + '\n';
      const std::size_t rest = line.find_first_not_of(' ', cut);
      line = rest == std::string::npos ? std::string() : line.substr(rest);
    }
    wrapped += line;
  }
  return wrapped;
}

}  // namespace

Studio::Impl::Impl(Studio& owner, vtkRenderWindow* window, vtkRenderWindowInteractor* interactor,
                   const StudioOptions& options)
    : owner(owner), window(window), interactor(interactor), options(options), pointBudget(options.pointBudget) {
  window->SetNumberOfLayers(3);
  window->SetMultiSamples(0);
  scene->SetBackground(0.10, 0.11, 0.13);
  scene->SetBackground2(0.22, 0.24, 0.28);
  scene->GradientBackgroundOn();
  sphere->SetBackground(0.07, 0.08, 0.09);
  plane->SetBackground(0.13, 0.14, 0.16);
  barBase->SetBackground(0.0, 0.0, 0.0);
  barBase->InteractiveOff();
  overlay->SetLayer(2);
  overlay->InteractiveOff();
  highlightLayer->SetLayer(1);
  highlightLayer->InteractiveOff();
  highlightLayer->SetActiveCamera(scene->GetActiveCamera());
  for (vtkRenderer* renderer : {scene.Get(), sphere.Get(), plane.Get(), barBase.Get(), highlightLayer.Get(), overlay.Get()})
    window->AddRenderer(renderer);
  plane->GetActiveCamera()->ParallelProjectionOn();

  style->panOnly = plane;
  interactor->SetInteractorStyle(style);
  observe(style, vtkCommand::StartInteractionEvent,
          [this](vtkObject*, unsigned long, void*) { setCoarsePoints(true); });
  observe(style, vtkCommand::EndInteractionEvent,
          [this](vtkObject*, unsigned long, void*) { setCoarsePoints(worker.joinable()); });
  observe(scene, vtkCommand::StartEvent, [this](vtkObject*, unsigned long, void*) { choosePointsInView(); });
  observe(interactor, vtkCommand::KeyPressEvent, [this](vtkObject*, unsigned long, void*) { onKey(); });
  // Passive: the camera style grabs the focus on a press, and the release must still reach picking.
  // (Clicks on the stage bar fall outside every view, so they pick nothing.)
  observe(
      interactor, vtkCommand::LeftButtonPressEvent, [this](vtkObject*, unsigned long, void*) { onLeftPress(); }, 0.0f,
      true);
  observe(
      interactor, vtkCommand::LeftButtonReleaseEvent, [this](vtkObject*, unsigned long, void*) { onLeftRelease(); },
      0.0f, true);

  // Hand-edit widgets. The box cannot rotate, so its bounds are the box `pipe fit-box` gets.
  vtkNew<vtkBoxRepresentation> boxRepresentation;
  boxRepresentation->SetPlaceFactor(1.0);
  boxRepresentation->GetOutlineProperty()->SetColor(1.0, 0.85, 0.2);
  boxRepresentation->GetOutlineProperty()->SetLineWidth(static_cast<float>(2.0 * options.uiScale));
  boxRepresentation->GetHandleProperty()->SetColor(1.0, 0.85, 0.2);
  // VTK widgets switch themselves on and off with the "i" key unless told not to; here they follow
  // the commands only (I colours the points by intensity, and "i" is typed in commands).
  fitBox->KeyPressActivationOff();
  fitBox->SetRepresentation(boxRepresentation);
  fitBox->SetInteractor(interactor);
  fitBox->SetDefaultRenderer(scene);
  fitBox->RotationEnabledOff();
  vtkNew<vtkPointHandleRepresentation3D> handleRepresentation;
  handleRepresentation->GetProperty()->SetColor(1.0, 0.85, 0.2);
  handleRepresentation->GetProperty()->SetLineWidth(static_cast<float>(2.0 * options.uiScale));
  handleRepresentation->SetHandleSize(24.0 * options.uiScale);
  endHandle->KeyPressActivationOff();
  endHandle->SetRepresentation(handleRepresentation);
  endHandle->SetInteractor(interactor);
  endHandle->SetDefaultRenderer(scene);
  observe(endHandle, vtkCommand::EndInteractionEvent, [this](vtkObject*, unsigned long, void*) {
    try {
      message = applyEndHandle();
    } catch (const std::exception& error) {
      message = error.what();
    }
    updateOverlays();
  });

  statusText = makeText(0.92, 0.92, 0.92);
  infoText = makeText(1.0, 0.9, 0.45);
  progressText = makeText(1.0, 0.8, 0.3);
  helpCommandsText = makeText(0.95, 0.95, 0.95);
  helpKeysText = makeText(0.95, 0.95, 0.95);
  for (auto* help : {helpCommandsText.Get(), helpKeysText.Get()}) {
    help->GetTextProperty()->SetBackgroundColor(0.05, 0.05, 0.08);
    help->GetTextProperty()->SetBackgroundOpacity(0.85);
    help->GetTextProperty()->SetFontFamilyToCourier();
    help->GetTextProperty()->SetVerticalJustificationToTop();
  }
  reviewText = makeText(0.95, 0.95, 0.95);
  reviewText->GetTextProperty()->SetBackgroundColor(0.05, 0.05, 0.08);
  reviewText->GetTextProperty()->SetBackgroundOpacity(0.7);
  reviewText->GetTextProperty()->SetJustificationToRight();
  reviewText->GetTextProperty()->SetVerticalJustificationToTop();
  noticeText = makeText(1.0, 0.82, 0.35);
  noticeText->GetTextProperty()->SetBackgroundColor(0.12, 0.08, 0.02);
  noticeText->GetTextProperty()->SetBackgroundOpacity(0.85);
  noticeText->GetTextProperty()->SetJustificationToCentered();
  noticeText->GetTextProperty()->SetVerticalJustificationToTop();
  sceneTitle = makeText(0.75, 0.8, 0.9);
  sphereTitle = makeText(0.75, 0.8, 0.9);
  planeTitle = makeText(0.75, 0.8, 0.9);
  statusText->GetTextProperty()->SetVerticalJustificationToTop();
  for (auto* title : {sceneTitle.Get(), sphereTitle.Get(), planeTitle.Get()}) {
    title->GetTextProperty()->SetVerticalJustificationToTop();
    title->GetTextProperty()->BoldOn();
  }
  for (auto* text : {statusText.Get(), infoText.Get(), progressText.Get(), sceneTitle.Get(), sphereTitle.Get(),
                     planeTitle.Get(), reviewText.Get(), noticeText.Get(), helpCommandsText.Get(), helpKeysText.Get()})
    overlay->AddViewProp(text);

  colorBar->SetLabelFormat("%.3g");  // the labels are round values (roundTicks, set with the map)
  colorBar->UnconstrainedFontSizeOn();
  colorBar->GetLabelTextProperty()->ShadowOff();
  colorBar->GetLabelTextProperty()->ItalicOff();
  colorBar->GetTitleTextProperty()->ShadowOff();
  colorBar->GetTitleTextProperty()->ItalicOff();
  colorBar->GetPositionCoordinate()->SetCoordinateSystemToDisplay();
  colorBar->GetPosition2Coordinate()->SetCoordinateSystemToDisplay();
  colorBar->VisibilityOff();
  overlay->AddViewProp(colorBar);

  // Joint status legend: each status's name in its colour.
  const std::array<std::pair<const char*, Rgb>, 3> statuses{
      {{"joint accepted", kAccepted}, {"joint proposed", kProposed}, {"joint rejected", kRejected}}};
  for (const auto& [label, color] : statuses) {
    auto text = makeText(color[0] / 255.0, color[1] / 255.0, color[2] / 255.0);
    text->SetInput(label);
    text->GetTextProperty()->BoldOn();
    text->GetTextProperty()->SetJustificationToRight();
    text->GetTextProperty()->SetVerticalJustificationToTop();
    overlay->AddViewProp(text);
    jointLegend.push_back(text);
  }

  stageBar = std::make_unique<StageBar>(
      interactor, overlay,
      [this](Stage stage) {
        try {
          message = this->owner.command(std::string("stage ") + stageName(stage));
          message = this->owner.command(std::string("run ") + stageName(stage));
        } catch (const std::exception& error) {
          message = error.what();
        }
        updateOverlays();
      },
      [this](const std::string& key, double value) {
        try {
          message = this->owner.command(std::string("rerun ") + stageName(selectedStage) + " " + key + "=" +
                                        format("%.6g", value));
        } catch (const std::exception& error) {
          message = error.what();
        }
        updateOverlays();
      });
  registerCommands();
  bindInterpreter();
  updateOverlays();
}

Studio::Impl::~Impl() {
  if (worker.joinable()) {
    runProgress->cancel();
    worker.join();
  }
}

// ---------------------------------------------------------------------------------------------
// Document

void Studio::Impl::bindInterpreter() {
  interpreter = std::make_unique<CommandInterpreter>(document.project(), document.pipeline());
  interpreter->setAutosaveInterval(options.autosaveEdits);
}

void Studio::Impl::open(Document opened) {
  if (worker.joinable()) throw CommandError("a run is in progress (Esc cancels it)");
  document = std::move(opened);
  bindInterpreter();
  reviewShown = false;
  noticeShown = !document.warnings().empty() || document.newerAutosave();
  if (const PointCloud* cloud = document.input().get()) {
    displayOrigin = cloud->origin;
    inputBounds = cloud->boundingBox();
    if (cloud->hasIntensity()) {
      const auto [low, high] = std::minmax_element(cloud->intensities.begin(), cloud->intensities.end());
      inputIntensities = {*low, *high};
    }
  } else {
    BoundingBox bounds;
    for (const auto& pipe : document.network().pipes) {
      bounds.extend(pipe.start);
      bounds.extend(pipe.end);
    }
    for (const auto& joint : document.network().joints)
      for (const auto& point : joint.axis) bounds.extend(point);
    displayOrigin = bounds.empty() ? Eigen::Vector3d::Zero() : Eigen::Vector3d(bounds.min);
  }
  fitBox->Off();  // Its box was in the old document's display co-ordinates.
  handlePipe = -1;
  selection = {};
  selectedDirection = -1;
  pointClip.reset();
  lastPointClip.reset();
  firstClipChosen = false;
  shownUp = upAxis();
  // Millions of 2-pixel points seen whole are a solid block; at 1 pixel the structure shows.
  scenePointSize = document.input() && document.input()->size() > kDenseScanPoints ? 1 : 2;
  straysHidden = false;
  strays.clear();
  viewMode = document.hasPipeline() ? ViewMode::All : ViewMode::Scene;
  pipeColor = std::any_of(document.network().pipes.begin(), document.network().pipes.end(),
                          [](const Pipe& pipe) { return pipe.runId >= 0; })
                  ? PipeColor::Run
                  : PipeColor::Radius;
  takeResults();
  rebuildAll();
  resetSceneCamera();
  resetSphereCamera();
  resetPlaneCamera();
  if (const auto fresh = document.freshThrough(); fresh && options.restoreStages) startRun({*fresh, false});
}

void Studio::Impl::takeResults() {
  const Pipeline* pipeline = document.pipeline();
  preprocessed = pipeline ? pipeline->preprocessResult() : nullptr;
  tiles = pipeline ? pipeline->tileResults() : nullptr;
  if (pipeline) tileParams = pipeline->tileParams();
  tilesMatchPreprocessed = pipeline && pipeline->tilesMatchPreprocessing();
  viewSamplesTile = -1;
  viewSamplesRounds.clear();
  inputDistances.reset();
  inputToKept.clear();
  segmentCache.clear();
  directions.clear();
  if (tiles) {
    for (std::size_t t = 0; t < tiles->size(); ++t) {
      const auto& rounds = (*tiles)[t].rounds;
      for (std::size_t r = 0; r < rounds.size(); ++r)
        for (std::size_t d = 0; d < rounds[r].directions.directions.size(); ++d)
          directions.push_back({static_cast<int>(t), static_cast<int>(r), static_cast<int>(d)});
    }
  }
  if (selectedDirection >= static_cast<int>(directions.size())) selectedDirection = -1;
  if (selectedDirection < 0 && !directions.empty()) selectedDirection = 0;
  if (selection.kind == Selection::Kind::Pipe && !document.network().findPipe(selection.id)) selection = {};
  if (selection.kind == Selection::Kind::Joint && !document.network().findJoint(selection.id)) selection = {};
  if (pipeColor == PipeColor::Run && std::none_of(document.network().pipes.begin(), document.network().pipes.end(),
                                                  [](const Pipe& pipe) { return pipe.runId >= 0; }))
    pipeColor = PipeColor::Radius;
  chooseFirstClip();
}

void Studio::Impl::chooseFirstClip() {
  if (firstClipChosen || !document.input() || document.network().pipes.empty()) return;
  firstClipChosen = true;
  if (const auto height = ceilingHeight(*document.input(), document.network(), upAxis()))
    pointClip = heightRange(-std::numeric_limits<double>::infinity(), *height, upAxis());
}

UpAxis Studio::Impl::upAxis() const { return document.project().params.up; }

bool Studio::Impl::followUpAxis() {
  if (upAxis() == shownUp) return false;
  shownUp = upAxis();
  for (auto* clip : {&pointClip, &lastPointClip}) {
    if (*clip && !(*clip)->min.allFinite()) clip->reset();  // A height clip; a box stays.
  }
  // The ceiling looked for along the old axis was none: look along the new one.
  if (!pointClip) {
    firstClipChosen = false;
    chooseFirstClip();
  }
  resetSceneCamera();
  resetSphereCamera();
  buildPointLayers();
  return true;
}

std::string Studio::Impl::pointClipText() const {
  if (!pointClip) return "points not clipped";
  const BoundingBox& clip = *pointClip;
  if (std::isfinite(clip.min.x())) {
    return "points outside the box from " + format("%.3f", clip.min.x()) + format(" %.3f", clip.min.y()) +
           format(" %.3f", clip.min.z()) + format(" to %.3f", clip.max.x()) + format(" %.3f", clip.max.y()) +
           format(" %.3f", clip.max.z()) + " hidden";
  }
  const auto [low, high] = heightLimits(clip, upAxis());
  if (!std::isfinite(low)) return format("points above %.2f m hidden", high);
  if (!std::isfinite(high)) return format("points below %.2f m hidden", low);
  return format("points shown from %.2f m", low) + format(" to %.2f m", high);
}

std::string Studio::Impl::pointClipCaption() const {
  const BoundingBox& clip = *pointClip;
  if (std::isfinite(clip.min.x())) {
    const Eigen::Vector3d size = clip.size();
    return format("box %.2f", size.x()) + format(" x %.2f", size.y()) + format(" x %.2f m", size.z());
  }
  const auto [low, high] = heightLimits(clip, upAxis());
  return (std::isfinite(low) ? format("%.2f < ", low) : std::string()) + toString(upAxis()) +
         (std::isfinite(high) ? format(" < %.2f", high) : std::string()) + " m";
}

void Studio::Impl::rebuildAll() {
  buildPointLayers();
  buildNetworkLayers();
  buildSelectionLayer();
  buildSphereLayers();
  buildPlaneLayers();
  stageBar->setEnabled(widgetsShown && document.hasPipeline());
  if (document.hasPipeline()) selectStage(selectedStage);
  updateOverlays();
}

const DirectionsResult* Studio::Impl::directionsOf(const DirectionRef& ref) const {
  return &(*tiles)[static_cast<std::size_t>(ref.tile)].rounds[static_cast<std::size_t>(ref.round)].directions;
}

const PlacementResult* Studio::Impl::placementOf(const DirectionRef& ref) const {
  return &(*tiles)[static_cast<std::size_t>(ref.tile)].rounds[static_cast<std::size_t>(ref.round)].placement;
}

const TileRound& Studio::Impl::viewRound(int tile, int round) const {
  const TileReconstruction& reconstruction = (*tiles)[static_cast<std::size_t>(tile)];
  if (!tilesMatchPreprocessed) return reconstruction.rounds[static_cast<std::size_t>(round)];
  if (viewSamplesTile != tile) {
    viewSamplesRounds.clear();
    for (std::size_t r = 0; r < reconstruction.rounds.size(); ++r)
      viewSamplesRounds.push_back(withViewSamples(*preprocessed, reconstruction, r, tileParams));
    viewSamplesTile = tile;
  }
  return viewSamplesRounds[static_cast<std::size_t>(round)];
}

const PrincipalDirection& Studio::Impl::direction(const DirectionRef& ref) const {
  return directionsOf(ref)->directions[static_cast<std::size_t>(ref.index)];
}

std::vector<int> Studio::Impl::keptPointSegments() const {
  // Each kept point takes the number of the (last) direction whose stripe holds it.
  std::vector<int> segments(preprocessed ? preprocessed->points.size() : 0, -1);
  for (std::size_t k = 0; k < directions.size(); ++k)
    for (std::uint32_t point : direction(directions[k]).stripe)
      if (point < segments.size()) segments[point] = static_cast<int>(k);
  return segments;
}

int Studio::Impl::pipeOfCylinder(const DirectionRef& ref, int cylinderIndex) const {
  // Merging loses which tile's cylinder became which pipe: match by axis, position and radius.
  const PlacementResult* placement = placementOf(ref);
  const Cylinder& cylinder = placement->cylinders[static_cast<std::size_t>(cylinderIndex)];
  const Eigen::Vector3d point = preprocessed->points.origin + cylinder.point;
  int best = -1;
  double bestDistance = std::max(2.0 * cylinder.radius, 0.03);
  for (const auto& pipe : document.network().pipes) {
    const Eigen::Vector3d axis = pipe.direction();
    if (std::abs(axis.dot(cylinder.direction)) < std::cos(5.0 * M_PI / 180.0)) continue;
    if (std::abs(pipe.radius - cylinder.radius) > 0.3 * cylinder.radius) continue;
    const Eigen::Vector3d offset = point - pipe.start;
    const double distance = (offset - offset.dot(axis) * axis).norm();
    if (distance < bestDistance) {
      bestDistance = distance;
      best = pipe.id;
    }
  }
  return best;
}

int Studio::Impl::directionShowingPipe(int pipeId) const {
  auto shows = [&](int k) {
    const DirectionRef& ref = directions[static_cast<std::size_t>(k)];
    const PlacementResult* placement = placementOf(ref);
    for (std::size_t c = 0; c < placement->cylinders.size(); ++c)
      if (placement->cylinders[c].directionIndex == ref.index && pipeOfCylinder(ref, static_cast<int>(c)) == pipeId)
        return true;
    return false;
  };
  if (selectedDirection >= 0 && shows(selectedDirection)) return selectedDirection;
  for (int k = 0; k < static_cast<int>(directions.size()); ++k)
    if (shows(k)) return k;
  return -1;
}

int Studio::Impl::directionOfTile(const std::string& word) const {
  if (directions.empty()) throw CommandError("no directions yet: run the directions stage");
  auto firstDirection = [&](int tile) {
    for (std::size_t k = 0; k < directions.size(); ++k)
      if (directions[k].tile == tile) return static_cast<int>(k);
    return -1;
  };
  const int tileCount = static_cast<int>(tiles->size());
  if (word == "next" || word == "previous") {
    const int step = word == "next" ? 1 : tileCount - 1;
    const int current = std::max(0, sphereTile());  // -1 on a scan of one tile
    for (int tile = (current + step) % tileCount;; tile = (tile + step) % tileCount)
      if (const int direction = firstDirection(tile); direction >= 0) return direction;  // The current tile has one.
  }
  const int id = parseInt(word, "the tile");
  for (int tile = 0; tile < tileCount; ++tile) {
    if (tileIdOf(tile) != id) continue;
    const int direction = firstDirection(tile);
    if (direction < 0) throw CommandError("tile " + word + " has no principal direction");
    return direction;
  }
  throw CommandError("no tile " + word + " (there are " + std::to_string(tileCount) + ")");
}

int Studio::Impl::tileIdOf(int tile) const { return (*tiles)[static_cast<std::size_t>(tile)].tileId; }

int Studio::Impl::sphereTile() const {
  if (!tiles || tiles->size() < 2) return -1;
  return selectedDirection >= 0 ? directions[static_cast<std::size_t>(selectedDirection)].tile : 0;
}

const Tile* Studio::Impl::sphereTilePoints() const {
  const int shown = sphereTile();
  if (shown < 0 || !preprocessed) return nullptr;
  const int tileId = tileIdOf(shown);
  for (const auto& tile : preprocessed->tiles)
    if (tile.id == tileId) return &tile;
  return nullptr;
}

std::optional<BoundingBox> Studio::Impl::sphereTileCube() const {
  const Tile* tile = sphereTilePoints();
  if (!tile) return std::nullopt;
  // The tiles' grid runs past the scan: the cube (without the overlap) is cut to the points' bounds.
  const BoundingBox bounds = preprocessed->points.boundingBox();
  BoundingBox cube;
  cube.min = tile->core.min.cwiseMax(bounds.min);
  cube.max = tile->core.max.cwiseMin(bounds.max);
  return cube;
}

// ---------------------------------------------------------------------------------------------
// Views and overlays

void Studio::Impl::layout() {
  const int* size = window->GetSize();
  const int width = std::max(1, size[0]), height = std::max(1, size[1]);
  const double scale = options.uiScale;
  const bool bar = stageBar->enabled();
  const double barHeight = bar ? 54.0 * scale : 0.0;
  const double bottom = barHeight / height;
  const double split = 0.64;
  struct Rect {
    double x0, y0, x1, y1;
  };
  Rect sceneRect{0, bottom, split, 1}, sphereRect{split, (1 + bottom) / 2, 1, 1},
      planeRect{split, bottom, 1, (1 + bottom) / 2};
  const Rect full{0, bottom, 1, 1}, none{0, 0, 0, 0};
  if (viewMode == ViewMode::Scene) sceneRect = full, sphereRect = none, planeRect = none;
  if (viewMode == ViewMode::Sphere) sceneRect = none, sphereRect = full, planeRect = none;
  if (viewMode == ViewMode::Plane) sceneRect = none, sphereRect = none, planeRect = full;
  auto apply = [](vtkRenderer* renderer, const Rect& rect) {
    const bool shown = rect.x1 > rect.x0;
    renderer->SetDraw(shown);
    renderer->SetInteractive(shown);
    if (shown) renderer->SetViewport(rect.x0, rect.y0, rect.x1, rect.y1);
  };
  apply(scene, sceneRect);
  apply(highlightLayer, sceneRect);
  highlightLayer->SetInteractive(false);
  apply(sphere, sphereRect);
  apply(plane, planeRect);
  showSphereTileBox();
  overlay->SetViewport(0, 0, 1, 1);
  barBase->SetDraw(bar);
  if (bar) barBase->SetViewport(0, 0, 1, bottom);

  const double pad = 8.0 * scale;
  auto place = [&](vtkTextActor* title, const Rect& rect, int fontSize) {
    title->SetVisibility(rect.x1 > rect.x0);
    title->SetPosition(rect.x0 * width + pad, rect.y1 * height - pad);
    title->GetTextProperty()->SetFontSize(static_cast<int>(fontSize * scale));
  };
  place(sceneTitle, sceneRect, 14);
  place(sphereTitle, sphereRect, 14);
  place(planeTitle, planeRect, 14);
  const Rect textRect = viewMode == ViewMode::All ? sceneRect : full;
  statusText->SetPosition(textRect.x0 * width + pad, textRect.y1 * height - pad - 22.0 * scale);
  statusText->GetTextProperty()->SetFontSize(static_cast<int>(13 * scale));
  infoText->SetPosition(textRect.x0 * width + pad, textRect.y0 * height + pad + 22.0 * scale);
  infoText->GetTextProperty()->SetFontSize(static_cast<int>(13 * scale));
  progressText->SetPosition(textRect.x0 * width + pad, textRect.y0 * height + pad);
  progressText->GetTextProperty()->SetFontSize(static_cast<int>(13 * scale));
  for (auto* help : {helpCommandsText.Get(), helpKeysText.Get()})
    help->GetTextProperty()->SetFontSize(static_cast<int>(11 * scale));
  // Top right, below the joint legend.
  reviewText->SetPosition(textRect.x1 * width - pad, textRect.y1 * height - pad - 58.0 * scale);
  reviewText->GetTextProperty()->SetFontSize(static_cast<int>(13 * scale));
  noticeText->SetPosition(0.5 * (textRect.x0 + textRect.x1) * width, textRect.y1 * height - 70.0 * scale);
  noticeText->GetTextProperty()->SetFontSize(static_cast<int>(14 * scale));
  // Characters of the notice's font (about 0.6 of its size wide) across the view, less the padding.
  noticeColumns = static_cast<std::size_t>(
      std::max(20.0, ((textRect.x1 - textRect.x0) * width - 4.0 * pad) / (0.6 * 14.0 * scale)));
  showNotice();
  // The info's font (digits and letters about half its size wide on average) across the view, less
  // the padding and the colour bar at its right, so its lines stay in the view and clear of the bar.
  infoColumns = static_cast<std::size_t>(
      std::max(20.0, ((textRect.x1 - textRect.x0) * width - 4.0 * pad - 100.0 * scale) / (0.5 * 13.0 * scale)));
  showInfo();
  helpCommandsText->SetPosition(pad * 2, height - 84.0 * scale);  // Below the status lines.
  placeKeysHelp();

  const double barRight = textRect.x1 * width - pad;
  colorBar->GetPositionCoordinate()->SetValue(barRight - 90.0 * scale, textRect.y0 * height + 60.0 * scale);
  colorBar->GetPosition2Coordinate()->SetValue(60.0 * scale,
                                               std::min(260.0 * scale, (textRect.y1 - textRect.y0) * height * 0.5));
  colorBar->SetBarRatio(0.3);
  colorBar->GetLabelTextProperty()->SetFontSize(static_cast<int>(11 * scale));
  colorBar->GetTitleTextProperty()->SetFontSize(static_cast<int>(11 * scale));
  for (std::size_t i = 0; i < jointLegend.size(); ++i) {
    jointLegend[i]->SetPosition(barRight, textRect.y1 * height - pad - 17.0 * scale * static_cast<double>(i));
    jointLegend[i]->GetTextProperty()->SetFontSize(static_cast<int>(12 * scale));
  }
  if (bar) stageBar->layout(width, static_cast<int>(barHeight), scale);
  laidOutWidth = width;
  laidOutHeight = height;
}

void Studio::Impl::resetSceneCamera() {
  vtkCamera* camera = scene->GetActiveCamera();
  const Eigen::Matrix3d turn = turnZUpTo(upAxis());
  camera->SetFocalPoint(0, 0, 0);
  camera->SetPosition(Eigen::Vector3d(turn * Eigen::Vector3d(0.55, 1.0, 0.8)).data());
  camera->SetViewUp(upVector(upAxis()).data());
  scene->ResetCamera();
  scene->ResetCameraClippingRange();
}

void Studio::Impl::resetSphereCamera() {
  vtkCamera* camera = sphere->GetActiveCamera();
  const Eigen::Matrix3d turn = turnZUpTo(upAxis());
  camera->SetFocalPoint(0, 0, 0);
  camera->SetPosition(Eigen::Vector3d(turn * Eigen::Vector3d(2.4, -3.6, 2.4)).data());
  camera->SetViewUp(upVector(upAxis()).data());
  camera->SetViewAngle(30.0);
  sphere->ResetCameraClippingRange();
}

void Studio::Impl::resetPlaneCamera() {
  vtkCamera* camera = plane->GetActiveCamera();
  double bounds[6];
  plane->ComputeVisiblePropBounds(bounds);
  if (bounds[0] > bounds[1]) return;
  const double cx = (bounds[0] + bounds[1]) / 2, cy = (bounds[2] + bounds[3]) / 2;
  camera->SetFocalPoint(cx, cy, 0);
  camera->SetPosition(cx, cy, 10);
  camera->SetViewUp(0, 1, 0);
  camera->SetParallelScale(0.55 * std::max(bounds[3] - bounds[2], bounds[1] - bounds[0]) + 1e-3);
  plane->ResetCameraClippingRange();
}

void Studio::Impl::flyTo(const Eigen::Vector3d& world, double size) {
  vtkCamera* camera = scene->GetActiveCamera();
  double position[3], focal[3];
  camera->GetPosition(position);
  camera->GetFocalPoint(focal);
  const Eigen::Vector3d viewDirection =
      (Eigen::Vector3d(position[0], position[1], position[2]) - Eigen::Vector3d(focal[0], focal[1], focal[2]))
          .normalized();
  const Eigen::Vector3d target = world - displayOrigin;
  const double distance = std::max(size, 0.05) * 1.2 / std::tan(camera->GetViewAngle() * M_PI / 360.0);
  const Eigen::Vector3d eye = target + distance * viewDirection;
  camera->SetFocalPoint(target.data());
  camera->SetPosition(eye.data());
  scene->ResetCameraClippingRange();
}

void Studio::Impl::placeKeysHelp() {
  // Right of the commands box, whose width depends on the font and the text (the bounding box is
  // relative to the text's position).
  double box[4];
  helpCommandsText->GetBoundingBox(overlay, box);
  const double* position = helpCommandsText->GetPosition();
  helpKeysText->SetPosition(position[0] + box[1] + 16.0 * options.uiScale, position[1]);
}

std::vector<StageState> Studio::Impl::stageStates() const {
  std::vector<StageState> states;
  const Pipeline* pipeline = document.pipeline();
  for (Stage stage : kAllStages) {
    const auto index = static_cast<std::size_t>(stage);
    if (worker.joinable()) {
      states.push_back(freshBeforeRun[index]                                          ? StageState::Fresh
                       : static_cast<int>(stage) <= static_cast<int>(pendingRun.last) ? StageState::Running
                                                                                      : StageState::Stale);
    } else {
      states.push_back(pipeline && pipeline->isFresh(stage) ? StageState::Fresh : StageState::Stale);
    }
  }
  return states;
}

void Studio::Impl::selectStage(Stage stage) {
  selectedStage = stage;
  const StageParameter* parameter = mainParameter(stage);
  const Pipeline* pipeline = document.pipeline();
  stageBar->setSelected(stage, parameter && pipeline ? parameterValue(pipeline->params(), parameter->key) : 0.0);
}

namespace {

/// How a pipe lies, for the selection's description: the heights of its axis (to the millimetre, as
/// elevations are given on drawings), and its slope; for a run (under 45°) the bottom and top of pipe
/// at its middle too.
std::string lieText(const Pipe& pipe, UpAxis up) {
  const PipeLie lie = pipeLie(pipe, up);
  std::ostringstream text;
  text << std::fixed << std::setprecision(3) << "height " << lie.lowHeight;
  if (std::round(1000.0 * lie.highHeight) != std::round(1000.0 * lie.lowHeight)) text << " to " << lie.highHeight;
  text << " m, ";
  if (lie.slopeDegrees < 45.0) {
    const double middle = 0.5 * (lie.lowHeight + lie.highHeight);
    text << "slope " << std::setprecision(1) << lie.slopeDegrees << "\u00b0 (" << lie.slopePercent() << " %); "
         << std::setprecision(3) << "bottom of pipe " << middle - pipe.radius << " m, top " << middle + pipe.radius
         << " m";
  } else {
    text << std::setprecision(1) << 90.0 - lie.slopeDegrees << "\u00b0 off vertical";
  }
  return text.str();
}

/// Where the second selected pipe is from the first.
std::string apartText(const Pipe& first, const Pipe& second) {
  const PipesApart apart = pipesApart(first, second);
  std::ostringstream text;
  text << std::fixed << std::setprecision(3) << "apart: axes " << apart.axisDistance << " m, surfaces ";
  if (apart.clearance >= 0.0) {
    text << apart.clearance << " m";
  } else {
    text << "overlap " << -apart.clearance << " m";
  }
  text << std::setprecision(1) << ", axes at " << apart.angleDegrees << "\u00b0";
  return text.str();
}

}  // namespace

std::string Studio::Impl::selectionInfo() const {
  const PipeNetwork& network = document.network();
  std::ostringstream info;
  info.precision(3);
  // A radius in millimetres, with the nominal size nearest it (what `radius snap` would set).
  const auto radius = [&](double metres) {
    std::ostringstream text;
    text.precision(3);
    text << metres * 1000.0 << " mm";
    if (const NominalSizes* sizes = interpreter ? interpreter->sizes() : nullptr) {
      const NominalSize& size = sizes->nearest(metres);
      text << " (" << size.nps << "\" DN " << size.dn << ")";
    }
    return text.str();
  };
  if (selection.kind == Selection::Kind::Pipe) {
    const Pipe& pipe = *network.findPipe(selection.id);
    info << "pipe " << pipe.id << "  radius " << radius(pipe.radius) << "  length " << pipe.length()
         << " m\nconfidence " << pipe.confidence << "  fit RMS " << pipe.fitRms * 1000.0 << " mm  inliers "
         << pipe.inlierCount << "  run " << (pipe.runId >= 0 ? std::to_string(pipe.runId) : "-") << "  "
         << toString(pipe.status) << "\n"
         << lieText(pipe, upAxis());
    if (const Pipe* second = network.findPipe(selection.secondPipe)) {
      info << "\nand pipe " << second->id << "  radius " << radius(second->radius) << "  length " << second->length()
           << " m  (Shift+M merges it into pipe " << pipe.id << ", Shift+J joins them)\n"
           << apartText(pipe, *second);
    }
  } else if (selection.kind == Selection::Kind::Joint) {
    const Joint& joint = *network.findJoint(selection.id);
    info << "joint " << joint.id << "  " << toString(joint.type) << "  " << toString(joint.status) << "  radius "
         << radius(joint.radius) << "  length " << joint.length() << " m";
    if (joint.type == JointType::Elbow) {
      info << "  bend radius " << joint.bendRadius << " m";
      // 90° or 45° says which fitting it is.
      if (const auto bend = bendOf(joint.axis)) {
        info << ", turning " << std::fixed << std::setprecision(1) << bend->angleDegrees() << "\u00b0"
             << std::defaultfloat << std::setprecision(3);
      }
    }
    info << "\nconfidence " << joint.confidence << "  pipes";
    for (int id : joint.pipeIds) info << " " << id;
  }
  if (selectedDirection >= 0) {
    const DirectionRef& ref = directions[static_cast<std::size_t>(selectedDirection)];
    const PrincipalDirection& chosen = direction(ref);
    const PlacementResult* placement = placementOf(ref);
    const auto cylinders = std::count_if(placement->cylinders.begin(), placement->cylinders.end(),
                                         [&](const Cylinder& c) { return c.directionIndex == ref.index; });
    if (selection.kind != Selection::Kind::None) info << "\n";
    info << "direction " << selectedDirection << " (tile " << tileIdOf(ref.tile)
         << ", round " << ref.round << ")  axis (" << chosen.axis.x() << ", " << chosen.axis.y() << ", "
         << chosen.axis.z() << ")  support " << chosen.support * 100.0 << " %  stripe " << chosen.stripe.size()
         << " points  " << cylinders << " cylinders";
  }
  return info.str();
}

std::string Studio::Impl::sceneCaption() const {
  std::string caption = "3-D scene  [points: " + nameOf(kPointColors, pointColor) +
                        (straysHidden ? " (strays hidden)" : "") + ", pipes: " + nameOf(kPipeColors, pipeColor) + "]";
  if (pointClip) caption += "  clip: " + pointClipCaption();
  if (const std::string drawn = pointBudgetCaption(); !drawn.empty()) caption += "  " + drawn;
  return caption;
}

void Studio::Impl::showNotice() {
  noticeText->SetVisibility(noticeShown);
  if (!noticeShown) return;
  std::string notice;
  for (const auto& warning : document.warnings()) notice += warning + "\n";
  if (document.newerAutosave())
    notice += "An autosave newer than this project exists: " + document.newerAutosave()->filename().string() +
              "\nCtrl+R recovers it (then Ctrl+S saves it over the project)";
  noticeText->SetInput(wrapLines(notice, noticeColumns).c_str());
}

void Studio::Impl::showInfo() { infoText->SetInput(wrapLines(selectionInfo(), infoColumns).c_str()); }

void Studio::Impl::updateOverlays() {
  const Pipeline* pipeline = document.pipeline();
  const PipeNetwork& network = document.network();
  std::ostringstream status;
  if (document.empty()) {
    status << "No file open: drop a scan or a network onto the window";
  } else {
    status << document.path().filename().string();
    // What is taken for granted otherwise is said: a scan read in another unit than metres (in which
    // everything is shown), and an up axis other than z.
    std::vector<std::string> notes;
    if (document.input()) {
      status << "  " << document.input()->size() << " points";
      if (document.project().scanUnits != "m") notes.push_back("read in " + document.project().scanUnits);
    }
    if (upAxis() != UpAxis::PlusZ) notes.push_back(toString(upAxis()) + " up");
    for (std::size_t i = 0; i < notes.size(); ++i) status << (i == 0 ? " (" : ", ") << notes[i];
    if (!notes.empty()) status << ")";
    status << "\n"
           << network.pipes.size() << " pipes  " << network.joints.size() << " joints  " << network.runs.size()
           << " runs";
    if (pipeline) status << "  " << directions.size() << " directions";
    if (tiles && tiles->size() > 1) status << " in " << tiles->size() << " tiles";
  }
  if (commandLine) {
    status << "\n:" << *commandLine << "_   (Return runs, Esc closes)";
  } else if (!message.empty()) {
    status << "\n" << message;
  }
  statusText->SetInput(status.str().c_str());
  showInfo();

  sceneTitle->SetInput(sceneCaption().c_str());
  std::string sphereCaption = "Gaussian sphere";
  if (const int tile = sphereTile(); tile >= 0)
    sphereCaption += " - tile " + std::to_string(tileIdOf(tile)) + " (of " +
                     std::to_string(tiles->size()) + ")";
  sphereTitle->SetInput(sphereCaption.c_str());
  std::string planeCaption = "Projection plane";
  if (selectedDirection >= 0) planeCaption += " - direction " + std::to_string(selectedDirection);
  planeTitle->SetInput(planeCaption.c_str());

  if (worker.joinable()) {
    std::lock_guard<std::mutex> lock(progressMutex);
    const int filled = static_cast<int>(std::lround(progressFraction * 30));
    progressText->SetInput(("running " + progressTask + " " + std::to_string(static_cast<int>(progressFraction * 100)) +
                            "% [" + std::string(static_cast<std::size_t>(filled), '#') +
                            std::string(static_cast<std::size_t>(30 - filled), '.') + "]  Esc cancels")
                               .c_str());
    progressText->VisibilityOn();
  } else {
    progressText->VisibilityOff();
  }

  // Usage only: the descriptions are in docs/STUDIO.md and `piperun-render --commands`.
  std::string commandHelp = "Commands\n";
  for (const auto* command : commands.list()) commandHelp += "  " + command->name + " " + command->arguments + "\n";
  std::string keyHelp = "Keys\n";
  for (const auto& line : keyHelpLines()) keyHelp += "  " + line + "\n";
  keyHelp += "\nLayers ([x] shown)\n";
  for (const auto& entry : layers)
    keyHelp += std::string("  [") + (layerVisible(entry.first) ? "x" : " ") + "] " + entry.first + "\n";
  helpCommandsText->SetInput(commandHelp.c_str());
  helpKeysText->SetInput(keyHelp.c_str());
  helpCommandsText->SetVisibility(helpShown);
  helpKeysText->SetVisibility(helpShown);
  if (helpShown) placeKeysHelp();

  const bool sceneShown = viewMode == ViewMode::All || viewMode == ViewMode::Scene;
  reviewText->SetVisibility(reviewShown && sceneShown);
  if (reviewShown) {
    const ReviewCounts joints = countJointReview(network);
    const ReviewCounts pipes = countPipeReview(network);
    std::ostringstream review;
    review << "Review  joints: " << joints.accepted << " accepted, " << joints.rejected << " rejected, " << joints.left
           << " left\npipes: " << pipes.left << " left, " << pipes.rejected << " deleted";
    const std::vector<ReviewItem> queue = reviewQueue(network);
    const std::optional<ReviewItem> selected = selectedReviewItem();
    const auto place = selected ? std::find(queue.begin(), queue.end(), *selected) : queue.end();
    if (place != queue.end())
      review << "\n" << (selected->kind == ReviewItem::Kind::Joint ? "joint " : "pipe ") << selection.id << ": "
             << (place - queue.begin() + 1) << " of " << queue.size() << " left";
    review << "\nN/P next/previous  A accept  R reject\nDel delete pipe  Ins restore  Ctrl+Z undo";
    reviewText->SetInput(review.str().c_str());
  }
  showNotice();

  if (document.hasPipeline() && stageBar->enabled()) stageBar->setStates(stageStates());
  for (auto& line : jointLegend)
    line->SetVisibility(!network.joints.empty() && layerVisible("network/joints") &&
                        (viewMode == ViewMode::All || viewMode == ViewMode::Scene));
  updateColorBar();
}

// ---------------------------------------------------------------------------------------------
// Running stages

std::string Studio::Impl::startRun(const CommandInterpreter::PendingRun& run) {
  Pipeline* pipeline = document.pipeline();
  if (!options.backgroundStages) {
    try {
      pipeline->run(Progress::none(), run.last);
    } catch (const Cancelled&) {
    }
    return finishRun(run).message;
  }
  for (Stage stage : kAllStages) freshBeforeRun[static_cast<std::size_t>(stage)] = pipeline->isFresh(stage);
  pendingRun = run;
  finished = false;
  runError = nullptr;
  {
    std::lock_guard<std::mutex> lock(progressMutex);
    progressTask = stageName(run.last);
    progressFraction = 0.0;
  }
  runProgress = std::make_unique<Progress>([this](const std::string& task, double fraction) {
    std::lock_guard<std::mutex> lock(progressMutex);
    progressTask = task;
    progressFraction = fraction;
    progressChanged = true;
  });
  setCoarsePoints(true);
  worker = std::thread([this, pipeline, last = run.last] {
    try {
      pipeline->run(*runProgress, last);
    } catch (...) {
      runError = std::current_exception();
    }
    finished = true;
  });
  updateOverlays();
  return std::string("running up to ") + stageName(run.last);
}

CommandOutcome Studio::Impl::finishRun(const CommandInterpreter::PendingRun& run) {
  CommandOutcome outcome = interpreter->finishRun(run);
  takeResults();
  followUpAxis();
  rebuildAll();
  if (layers.count("plane/points")) resetPlaneCamera();
  // Edits that could not be carried onto the new network are listed, never dropped silently.
  for (const DroppedEdit& dropped : outcome.dropped)
    outcome.message += "\nnot carried over: " + dropped.command + ": " + dropped.reason;
  return outcome;
}

bool Studio::Impl::poll() {
  bool changed = progressChanged.exchange(false);
  if (worker.joinable() && finished) {
    worker.join();
    setCoarsePoints(false);
    std::string ending;
    try {
      if (runError) std::rethrow_exception(runError);
      ending = "finished: ";
    } catch (const Cancelled&) {
      ending = "cancelled: the stages that had finished are kept; ";
    } catch (const std::exception& error) {
      ending = std::string("run failed: ") + error.what() + "; ";
    }
    message = ending + finishRun(pendingRun).message;
    if (options.runFinished) options.runFinished(message);
    changed = true;
  }
  if (changed) updateOverlays();
  return changed;
}

// ---------------------------------------------------------------------------------------------
// Review and edits

std::string Studio::Impl::edit(const std::string& line) {
  // The pipeline and the project belong to a background run until it ends; saving reads only the project.
  if (worker.joinable() && line.rfind("save", 0) != 0) throw CommandError("a run is in progress (Esc cancels it)");
  CommandOutcome outcome;
  try {
    outcome = interpreter->execute(line);
  } catch (const piperun::CommandError& error) {
    throw CommandError(error.what());
  }
  if (outcome.networkChanged) networkChanged();
  return outcome.message;
}

std::string Studio::Impl::editSelectingNewPipe(const std::string& line) {
  std::vector<int> before;
  for (const Pipe& pipe : document.network().pipes) before.push_back(pipe.id);
  const std::string fitted = edit(line);
  for (const Pipe& pipe : document.network().pipes)
    if (std::find(before.begin(), before.end(), pipe.id) == before.end())
      commands.run("select pipe " + std::to_string(pipe.id));
  return fitted;
}

void Studio::Impl::networkChanged() {
  const PipeNetwork& network = document.network();
  if (selection.kind == Selection::Kind::Pipe && !network.findPipe(selection.id)) selection = {};
  if (selection.kind == Selection::Kind::Joint && !network.findJoint(selection.id)) selection = {};
  if (selection.secondPipe >= 0 && !network.findPipe(selection.secondPipe)) selection.secondPipe = -1;
  noticeShown = false;
  inputDistances.reset();
  if (document.input() && (pointColor == PointColor::Element || pointColor == PointColor::Qa)) buildPointLayers();
  buildNetworkLayers();
  buildSelectionLayer();
  buildPlaneLayers();
  updateOverlays();
}

std::optional<ReviewItem> Studio::Impl::selectedReviewItem() const {
  const PipeNetwork& network = document.network();
  if (const Joint* joint = selection.kind == Selection::Kind::Joint ? network.findJoint(selection.id) : nullptr) {
    return ReviewItem{ReviewItem::Kind::Joint, joint->id, joint->confidence};
  }
  if (const Pipe* pipe = selection.kind == Selection::Kind::Pipe ? network.findPipe(selection.id) : nullptr) {
    return ReviewItem{ReviewItem::Kind::Pipe, pipe->id, pipe->confidence};
  }
  return std::nullopt;
}

std::optional<ReviewItem> Studio::Impl::reviewNeighbour(bool forward) const {
  const std::vector<ReviewItem> queue = reviewQueue(document.network());
  if (queue.empty()) return std::nullopt;
  // The queue's order places even a decided element between its neighbours.
  const std::optional<ReviewItem> current = selectedReviewItem();
  if (!current) return forward ? queue.front() : queue.back();
  if (forward) {
    for (const ReviewItem& item : queue)
      if (reviewsBefore(*current, item)) return item;
    return queue.front();
  }
  for (auto item = queue.rbegin(); item != queue.rend(); ++item)
    if (reviewsBefore(*item, *current)) return *item;
  return queue.back();
}

std::string Studio::Impl::reviewItem(const std::optional<ReviewItem>& item) {
  reviewShown = true;
  if (!item) {
    updateOverlays();
    return "nothing proposed left to review";
  }
  const bool joint = item->kind == ReviewItem::Kind::Joint;
  const std::string selected = commands.run((joint ? "select joint " : "select pipe ") + std::to_string(item->id));
  commands.run("fly");
  return selected;
}

std::filesystem::path Studio::Impl::defaultProjectPath() const {
  if (!document.project().file.empty()) return document.project().file;
  if (document.path().empty()) throw CommandError("nothing to save: open a scan, network or project first");
  return std::filesystem::path(document.path()).replace_extension(".piperun");
}

// ---------------------------------------------------------------------------------------------
// Interaction

void Studio::Impl::onKey() {
  std::string key = interactor->GetKeySym() ? interactor->GetKeySym() : "";
  std::transform(key.begin(), key.end(), key.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (commandLineKey(key)) return;
  if (interactor->GetControlKey()) key = "ctrl+" + key;
  // Shift+key runs its own binding when it has one, else the key's (Shift+N is N).
  const std::string shifted = "shift+" + key;
  if (interactor->GetShiftKey() && std::any_of(keyBindings.begin(), keyBindings.end(),
                                               [&](const auto& binding) { return binding.first == shifted; }))
    key = shifted;
  for (const auto& [boundKey, binding] : keyBindings) {
    if (boundKey != key) continue;
    // "X Y" in a binding is the pixel under the mouse.
    std::string line = binding;
    const std::size_t pixel = line.find(" X Y");
    if (pixel != std::string::npos) {
      const int* position = interactor->GetEventPosition();
      line.replace(pixel, 4, " " + std::to_string(position[0]) + " " + std::to_string(position[1]));
    }
    try {
      message = commands.run(line);
    } catch (const std::exception& error) {
      message = error.what();
    }
    updateOverlays();
    return;
  }
}

bool Studio::Impl::commandLineKey(const std::string& key) {
  if (!commandLine) return false;
  // While the command line is open, keys edit it instead of running their bindings.
  if (key == "return") {
    const std::string line = *commandLine;
    commandLine.reset();
    try {
      message = line.empty() ? std::string() : commands.run(line);
    } catch (const std::exception& error) {
      message = error.what();
    }
  } else if (key == "escape") {
    commandLine.reset();
  } else if (key == "backspace" && !commandLine->empty()) {
    commandLine->pop_back();
  }
  updateOverlays();
  return true;
}

void Studio::Impl::typeCharacter(unsigned codepoint) {
  if (codepoint < 0x20 || codepoint > 0x7e) return;  // Commands are ASCII.
  const char character = static_cast<char>(codepoint);
  if (!commandLine) {
    if (character != ':') return;
    commandLine.emplace();
  } else {
    commandLine->push_back(character);
  }
  updateOverlays();
}

void Studio::Impl::onLeftPress() {
  const int* position = interactor->GetEventPosition();
  pressX = position[0];
  pressY = position[1];
}

void Studio::Impl::onLeftRelease() {
  const int* position = interactor->GetEventPosition();
  if (std::abs(position[0] - pressX) > 3 || std::abs(position[1] - pressY) > 3) return;  // A drag, not a click.
  const auto now = std::chrono::steady_clock::now();
  const bool doubleClick = now - lastClickTime < std::chrono::milliseconds(400) &&
                           std::abs(position[0] - lastClickX) < 6 && std::abs(position[1] - lastClickY) < 6;
  lastClickTime = now;
  lastClickX = position[0];
  lastClickY = position[1];
  pick(position[0], position[1], doubleClick, interactor->GetShiftKey() != 0);
  updateOverlays();
}

void Studio::Impl::pick(int x, int y, bool doubleClick, bool addPipe) {
  vtkNew<vtkCellPicker> picker;
  picker->SetTolerance(0.004);
  auto pickedElement = [&](vtkRenderer* renderer, std::initializer_list<const char*> names, std::string& layer) {
    picker->InitializePickList();
    for (const char* name : names)
      if (layerVisible(name)) picker->AddPickList(layers[name].prop);
    picker->PickFromListOn();
    if (!picker->Pick(x, y, 0, renderer)) return -1;
    for (const char* name : names)
      if (layers.count(name) && layers[name].prop == picker->GetActor()) layer = name;
    auto* elements = vtkIntArray::SafeDownCast(picker->GetDataSet()->GetCellData()->GetArray(kElementArray));
    return elements ? elements->GetValue(picker->GetCellId()) : -1;
  };
  try {
    std::string layer;
    if (scene->GetDraw() && scene->IsInViewport(x, y)) {
      const int element = pickedElement(
          scene, {"network/joints", "network/rejected-joints", "network/pipes", "network/deleted-pipes"}, layer);
      if (element < 0) {
        message = commands.run("select none");
        return;
      }
      const std::string kind = layer.find("joints") != std::string::npos ? "joint" : "pipe";
      if (addPipe && kind == "pipe" && selection.kind == Selection::Kind::Pipe && selection.id != element) {
        message = commands.run("select pipe " + std::to_string(selection.id) + " " + std::to_string(element));
        return;
      }
      message = commands.run("select " + kind + " " + std::to_string(element));
      if (doubleClick) commands.run("fly");
    } else if (sphere->GetDraw() && sphere->IsInViewport(x, y)) {
      const int element = pickedElement(sphere, {"sphere/directions"}, layer);
      if (element >= 0) message = commands.run("select direction " + std::to_string(element));
    } else if (plane->GetDraw() && plane->IsInViewport(x, y) && selectedDirection >= 0) {
      // The circle the click falls in (the smallest, if several), else the one whose outline passes
      // nearest, within a quarter of its radius or 6 pixels.
      plane->SetDisplayPoint(x, y, 0.0);
      plane->DisplayToWorld();
      const double* world = plane->GetWorldPoint();
      const Eigen::Vector2d clicked(world[0] / world[3], world[1] / world[3]);
      const int* viewportSize = plane->GetSize();
      const double metresPerPixel = 2.0 * plane->GetActiveCamera()->GetParallelScale() / std::max(1, viewportSize[1]);
      const DirectionRef& ref = directions[static_cast<std::size_t>(selectedDirection)];
      const PlacementResult* placement = placementOf(ref);
      if (ref.index >= static_cast<int>(placement->projections.size())) return;
      const auto& projection = placement->projections[static_cast<std::size_t>(ref.index)];
      int best = -1;
      std::pair<double, double> bestScore{1e9, 1e9};  // (distance outside the circle, radius)
      for (std::size_t c = 0; c < placement->cylinders.size(); ++c) {
        const Cylinder& cylinder = placement->cylinders[c];
        if (cylinder.directionIndex != ref.index) continue;
        const Eigen::Vector2d center(cylinder.point.dot(projection.u), cylinder.point.dot(projection.v));
        const double outside = std::max(0.0, (clicked - center).norm() - cylinder.radius);
        const std::pair<double, double> score{outside, cylinder.radius};
        if (outside <= std::max(0.25 * cylinder.radius, 6.0 * metresPerPixel) && score < bestScore) {
          bestScore = score;
          best = static_cast<int>(c);
        }
      }
      if (best < 0) return;
      const int pipe = pipeOfCylinder(ref, best);
      message = pipe >= 0 ? commands.run("select pipe " + std::to_string(pipe))
                          : "circle " + std::to_string(best) + " did not become a pipe";
    }
  } catch (const std::exception& error) {
    message = error.what();
  }
}

std::optional<std::pair<Eigen::Vector3d, int>> Studio::Impl::pickSurface(int x, int y,
                                                                      std::initializer_list<const char*> names) {
  if (!scene->GetDraw() || !scene->IsInViewport(x, y)) return std::nullopt;
  vtkNew<vtkCellPicker> picker;
  picker->SetTolerance(0.004);
  picker->PickFromListOn();
  std::vector<vtkProp*> madePickable;  // Point layers are not pickable by clicks; here they are.
  for (const char* name : names) {
    if (!layerVisible(name)) continue;
    vtkProp* prop = layers[name].prop;
    if (!prop->GetPickable()) {
      prop->PickableOn();
      madePickable.push_back(prop);
    }
    picker->AddPickList(prop);
  }
  const bool hit = picker->Pick(x, y, 0, scene) != 0;
  for (vtkProp* prop : madePickable) prop->PickableOff();
  if (!hit) return std::nullopt;
  const double* position = picker->GetPickPosition();
  auto* elements = vtkIntArray::SafeDownCast(picker->GetDataSet()->GetCellData()->GetArray(kElementArray));
  const int element = elements ? elements->GetValue(picker->GetCellId()) : -1;
  return std::make_pair(Eigen::Vector3d(position[0], position[1], position[2]) + displayOrigin, element);
}

std::pair<int, int> Studio::Impl::selectedPipePair(const char* action) const {
  if (selection.kind != Selection::Kind::Pipe || selection.secondPipe < 0)
    throw CommandError(std::string("select two pipes to ") + action + " (click one, Shift+click the other)");
  return {selection.id, selection.secondPipe};
}

void Studio::Impl::showFitBox(const std::array<double, 6>& bounds) {
  double shown[6];
  for (int axis = 0; axis < 3; ++axis) {
    shown[2 * axis] = bounds[2 * axis] - displayOrigin[axis];
    shown[2 * axis + 1] = bounds[2 * axis + 1] - displayOrigin[axis];
  }
  fitBox->GetRepresentation()->PlaceWidget(shown);
  fitBox->On();
}

BoundingBox Studio::Impl::fitBoxBounds() const {
  if (!fitBox->GetEnabled()) throw CommandError("no box shown (box show, or B)");
  const double* shown = fitBox->GetRepresentation()->GetBounds();
  BoundingBox box;
  box.extend(Eigen::Vector3d(shown[0], shown[2], shown[4]) + displayOrigin);
  box.extend(Eigen::Vector3d(shown[1], shown[3], shown[5]) + displayOrigin);
  return box;
}

void Studio::Impl::placeEndHandle() {
  const Pipe* pipe = selection.kind == Selection::Kind::Pipe ? document.network().findPipe(selection.id) : nullptr;
  if (!handleOn || !pipe) {
    handlePipe = -1;
    endHandle->Off();
    return;
  }
  if (pipe->id != handlePipe) {
    const double* eye = scene->GetActiveCamera()->GetPosition();
    const Eigen::Vector3d camera = Eigen::Vector3d(eye[0], eye[1], eye[2]) + displayOrigin;
    handleAtStart = (pipe->start - camera).norm() <= (pipe->end - camera).norm();
    handlePipe = pipe->id;
  }
  Eigen::Vector3d position = (handleAtStart ? pipe->start : pipe->end) - displayOrigin;
  auto* representation = vtkHandleRepresentation::SafeDownCast(endHandle->GetRepresentation());
  representation->SetWorldPosition(position.data());
  endHandle->On();
}

std::string Studio::Impl::applyEndHandle() {
  if (handlePipe < 0) throw CommandError("no end handle shown: select a pipe and turn the handle on");
  double position[3];
  vtkHandleRepresentation::SafeDownCast(endHandle->GetRepresentation())->GetWorldPosition(position);
  const Eigen::Vector3d world = Eigen::Vector3d(position[0], position[1], position[2]) + displayOrigin;
  const Pipe* pipe = document.network().findPipe(handlePipe);
  if (pipe && (world - (handleAtStart ? pipe->start : pipe->end)).norm() < 1e-9)
    return "pipe " + std::to_string(handlePipe) + ": end not moved";  // A click on the handle is no edit.
  return edit("pipe " + std::to_string(handlePipe) + " move-end " + (handleAtStart ? "start " : "end ") +
              formatPoint(world));
}

// ---------------------------------------------------------------------------------------------
// Studio

Studio::Studio(vtkRenderWindow* window, vtkRenderWindowInteractor* interactor, const StudioOptions& options)
    : impl_(std::make_unique<Impl>(*this, window, interactor, options)) {}

Studio::~Studio() = default;

void Studio::open(Document document) { impl_->open(std::move(document)); }

void Studio::open(const std::filesystem::path& path) {
  impl_->open(Document::open(path, Progress::none(), impl_->options.scanUnits, impl_->options.up));
}

const Document& Studio::document() const { return impl_->document; }

std::string Studio::command(const std::string& line) {
  try {
    impl_->message = impl_->commands.run(line);
  } catch (const std::exception& error) {
    impl_->message = error.what();  // The status line shows what went wrong too.
    impl_->updateOverlays();
    throw;
  }
  impl_->updateOverlays();
  return impl_->message;
}

void Studio::runScript(const std::filesystem::path& path) {
  if (impl_->worker.joinable()) throw CommandError("a run is in progress (Esc cancels it)");
  // Each line sees what the one before did: a script's runs finish before its next line.
  const bool background = impl_->options.backgroundStages;
  impl_->options.backgroundStages = false;
  try {
    impl_->message = impl_->commands.runScript(path);
  } catch (...) {
    impl_->options.backgroundStages = background;
    impl_->updateOverlays();
    throw;
  }
  impl_->options.backgroundStages = background;
  impl_->updateOverlays();
}

const CommandRegistry& Studio::commands() const { return impl_->commands; }

std::vector<std::string> Studio::keyHelpLines() const { return impl_->keyHelpLines(); }

void Studio::typeText(unsigned codepoint) { impl_->typeCharacter(codepoint); }

bool Studio::poll() { return impl_->poll(); }

void Studio::render() {
  const int* size = impl_->window->GetSize();
  if (size[0] != impl_->laidOutWidth || size[1] != impl_->laidOutHeight) impl_->layout();
  impl_->window->Render();
}

bool Studio::busy() const { return impl_->worker.joinable(); }

void Studio::cancel() {
  if (impl_->worker.joinable()) impl_->runProgress->cancel();
}

std::string Studio::title() const {
  const auto& file = impl_->document.project().file;
  const auto& path = file.empty() ? impl_->document.path() : file;
  return path.empty() ? std::string("PipeRun Studio") : "PipeRun Studio - " + path.filename().string();
}

bool Studio::quitRequested() const { return impl_->quit; }

const std::string& Studio::message() const { return impl_->message; }

std::string Studio::overlayText() const {
  const Impl& impl = *impl_;
  const std::vector<std::pair<const char*, vtkTextActor*>> texts{
      {"scene title", impl.sceneTitle},   {"sphere title", impl.sphereTitle}, {"plane title", impl.planeTitle},
      {"status", impl.statusText},        {"info", impl.infoText},            {"progress", impl.progressText},
      {"review", impl.reviewText},        {"notice", impl.noticeText},        {"help commands", impl.helpCommandsText},
      {"help keys", impl.helpKeysText}};
  std::string text;
  for (const auto& [name, actor] : texts) {
    const char* input = actor->GetInput();
    if (actor->GetVisibility() && input && *input) text += std::string("[") + name + "]\n" + input + "\n";
  }
  if (impl.colorBar->GetVisibility() && impl.colorBar->GetTitle())
    text += std::string("[colour bar]\n") + impl.colorBar->GetTitle() + "\n";
  return text;
}

}  // namespace piperun::ui
