#include "piperun/ui/studio.h"

#include "mesh.h"
#include "observe.h"
#include "palette.h"
#include "point_measures.h"
#include "stage_bar.h"

#include "piperun/error.h"
#include "piperun/params.h"

#include <nlohmann/json.hpp>

#include <vtkActor.h>
#include <vtkCallbackCommand.h>
#include <vtkCamera.h>
#include <vtkCellData.h>
#include <vtkCellPicker.h>
#include <vtkIntArray.h>
#include <vtkInteractorStyleTrackballCamera.h>
#include <vtkLookupTable.h>
#include <vtkObjectFactory.h>
#include <vtkPNGWriter.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>
#include <vtkRenderWindow.h>
#include <vtkRenderWindowInteractor.h>
#include <vtkRenderer.h>
#include <vtkScalarBarActor.h>
#include <vtkTextActor.h>
#include <vtkTextProperty.h>
#include <vtkWindowToImageFilter.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <mutex>
#include <sstream>
#include <thread>

namespace piperun::ui {

namespace {

/// Trackball rotation in the 3-D scene and the sphere, panning in the projection plane; the keys
/// are the studio's (VTK's defaults such as 'e' = exit or 'w' = wireframe are switched off).
class StudioInteractorStyle : public vtkInteractorStyleTrackballCamera {
 public:
  static StudioInteractorStyle* New();
  vtkTypeMacro(StudioInteractorStyle, vtkInteractorStyleTrackballCamera);

  vtkRenderer* panOnly = nullptr;

  void OnChar() override {}
  void OnKeyPress() override {}
  void OnKeyRelease() override {}
  void OnLeftButtonDown() override {
    const int* position = this->Interactor->GetEventPosition();
    this->FindPokedRenderer(position[0], position[1]);
    if (this->CurrentRenderer && this->CurrentRenderer == panOnly) {
      this->GrabFocus(this->EventCallbackCommand);
      this->StartPan();
      return;
    }
    vtkInteractorStyleTrackballCamera::OnLeftButtonDown();
  }
};
vtkStandardNewMacro(StudioInteractorStyle);

enum class ViewMode { All, Scene, Sphere, Plane };
enum class PointColor { Height, Intensity, Rgb, Segment, Element, Qa };
enum class PipeColor { Run, Radius, Confidence, Plain };

const std::map<std::string, ViewMode> kViewModes{
    {"all", ViewMode::All}, {"scene", ViewMode::Scene}, {"sphere", ViewMode::Sphere}, {"plane", ViewMode::Plane}};
const std::map<std::string, PointColor> kPointColors{{"height", PointColor::Height},   {"intensity", PointColor::Intensity},
                                                     {"rgb", PointColor::Rgb},         {"segment", PointColor::Segment},
                                                     {"element", PointColor::Element}, {"qa", PointColor::Qa}};
const std::map<std::string, PipeColor> kPipeColors{
    {"run", PipeColor::Run}, {"radius", PipeColor::Radius}, {"confidence", PipeColor::Confidence}, {"plain", PipeColor::Plain}};

template <typename Value>
std::string nameOf(const std::map<std::string, Value>& names, Value value) {
  for (const auto& [name, candidate] : names)
    if (candidate == value) return name;
  return {};
}

template <typename Value>
Value parseName(const std::map<std::string, Value>& names, const std::string& word, const char* what) {
  const auto found = names.find(word);
  if (found != names.end()) return found->second;
  std::string known;
  for (const auto& entry : names) known += (known.empty() ? "" : "|") + entry.first;
  throw CommandError(std::string("unknown ") + what + " '" + word + "' (expected " + known + ")");
}

int parseInt(const std::string& word, const char* what) {
  try {
    std::size_t used = 0;
    const int value = std::stoi(word, &used);
    if (used == word.size()) return value;
  } catch (const std::exception&) {
  }
  throw CommandError(std::string("expected ") + what + " as an integer, got '" + word + "'");
}

double parseDouble(const std::string& word, const char* what) {
  try {
    std::size_t used = 0;
    const double value = std::stod(word, &used);
    if (used == word.size()) return value;
  } catch (const std::exception&) {
  }
  throw CommandError(std::string("expected ") + what + " as a number, got '" + word + "'");
}

void expectArguments(const std::vector<std::string>& args, std::size_t minimum, std::size_t maximum, const char* usage) {
  if (args.size() < minimum || args.size() > maximum) throw CommandError(std::string("usage: ") + usage);
}

std::string format(const char* pattern, double value) {
  char text[64];
  std::snprintf(text, sizeof text, pattern, value);
  return text;
}

/// The value of "section.key" in the parameters.
double parameterValue(const PipelineParams& params, const std::string& key) {
  const nlohmann::json document = nlohmann::json::parse(paramsToJson(params));
  const std::size_t dot = key.find('.');
  const nlohmann::json& value = document.at(key.substr(0, dot)).at(key.substr(dot + 1));
  return value.is_boolean() ? (value.get<bool>() ? 1.0 : 0.0) : value.get<double>();
}

/// A principal direction of one tile's round, numbered across all tiles for the views.
struct DirectionRef {
  int tile = 0;       ///< Index into the pipeline's tile results.
  int round = 0;
  int index = 0;      ///< Index into the round's DirectionsResult::directions.
};

struct Selection {
  enum class Kind { None, Pipe, Joint } kind = Kind::None;
  int id = 0;
};

/// A points layer drawn whole when the camera is still and as a subsample while it moves.
struct PointLayerLod {
  vtkSmartPointer<vtkPolyDataMapper> mapper;
  vtkSmartPointer<vtkPolyData> full;
  vtkSmartPointer<vtkPolyData> coarse;
};

struct Layer {
  vtkRenderer* renderer = nullptr;
  vtkSmartPointer<vtkProp> prop;
};

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

constexpr double kQaReach = 0.02;  ///< Points farther than this from every surface are not coloured by the QA map (m).

}  // namespace

struct Studio::Impl {
  Impl(Studio& owner, vtkRenderWindow* window, vtkRenderWindowInteractor* interactor, const StudioOptions& options);
  ~Impl();

  // Document and derived data.
  void open(Document opened);
  void takeResults();
  void rebuildAll();
  Eigen::Vector3f toDisplay(const Eigen::Vector3d& world) const { return (world - displayOrigin).cast<float>(); }
  const DirectionsResult* directionsOf(const DirectionRef& ref) const;
  const PlacementResult* placementOf(const DirectionRef& ref) const;
  const PrincipalDirection& direction(const DirectionRef& ref) const;
  std::vector<int> keptPointSegments() const;
  int pipeOfCylinder(const DirectionRef& ref, int cylinder) const;

  // Layers.
  void setLayer(const std::string& name, vtkRenderer* renderer, vtkSmartPointer<vtkProp> prop, bool defaultVisible);
  void removeLayer(const std::string& name);
  bool layerVisible(const std::string& name) const;
  void setPointLayer(const std::string& name, const std::vector<Eigen::Vector3f>& positions, const std::vector<Rgb>& colors,
                     double pointSize, bool defaultVisible);
  void buildPointLayers();
  std::vector<Rgb> inputPointColors();
  void buildNetworkLayers();
  void buildSelectionLayer();
  void buildSphereLayers();
  void buildPlaneLayers();
  void updateColorBar();

  // Views, overlays, cameras.
  void layout();
  void resetSceneCamera();
  void resetSphereCamera();
  void resetPlaneCamera();
  void flyTo(const Eigen::Vector3d& world, double size);
  void updateOverlays();
  std::string selectionInfo() const;
  std::vector<StageState> stageStates() const;
  void selectStage(Stage stage);

  // Running stages.
  void startRun(Stage last);
  void finishRun();
  bool poll();

  // Interaction.
  void onKey();
  void onLeftPress();
  void onLeftRelease();
  void pick(int x, int y, bool doubleClick);
  void registerCommands();
  std::vector<std::string> keyHelpLines() const;

  Studio& owner;
  vtkRenderWindow* window;
  vtkRenderWindowInteractor* interactor;
  StudioOptions options;
  vtkNew<vtkRenderer> scene, sphere, plane, overlay;
  vtkNew<vtkRenderer> highlightLayer;  ///< Over the scene, sharing its camera.
  vtkNew<StudioInteractorStyle> style;
  CommandRegistry commands;
  std::vector<std::pair<std::string, std::string>> keyBindings;  ///< key, command

  Document document;
  Eigen::Vector3d displayOrigin = Eigen::Vector3d::Zero();
  std::shared_ptr<const PreprocessResult> preprocessed;
  std::shared_ptr<const std::vector<TileReconstruction>> tiles;
  std::vector<DirectionRef> directions;
  std::optional<SurfaceDistances> inputDistances;
  std::vector<int> inputToKept;
  std::vector<int> segmentCache;

  std::map<std::string, Layer> layers;
  std::map<std::string, bool> visibility;  ///< Kept by name across re-registration.
  std::map<std::string, PointLayerLod> pointLods;
  bool interacting = false;

  ViewMode viewMode = ViewMode::All;
  PointColor pointColor = PointColor::Height;
  PipeColor pipeColor = PipeColor::Run;
  Selection selection;
  int selectedDirection = -1;
  Stage selectedStage = Stage::Placement;
  bool helpShown = false;
  bool widgetsShown = true;
  bool quit = false;
  std::string message;

  vtkSmartPointer<vtkTextActor> statusText, infoText, helpCommandsText, helpKeysText, progressText;
  vtkSmartPointer<vtkTextActor> sceneTitle, sphereTitle, planeTitle;
  vtkNew<vtkScalarBarActor> colorBar;
  std::vector<vtkSmartPointer<vtkTextActor>> jointLegend;  ///< One line per joint status.
  std::unique_ptr<StageBar> stageBar;
  int laidOutWidth = 0, laidOutHeight = 0;

  // Background run: the worker thread alone touches the pipeline until `finished`.
  std::thread worker;
  std::atomic<bool> finished{false};
  std::unique_ptr<Progress> runProgress;
  std::exception_ptr runError;
  std::mutex progressMutex;
  std::string progressTask;
  double progressFraction = 0.0;
  std::atomic<bool> progressChanged{false};
  std::array<bool, kStageCount> freshBeforeRun{};
  Stage runLast = Stage::Preprocess;

  // Click detection.
  int pressX = 0, pressY = 0;
  std::chrono::steady_clock::time_point lastClickTime;
  int lastClickX = -100, lastClickY = -100;
};

Studio::Impl::Impl(Studio& owner, vtkRenderWindow* window, vtkRenderWindowInteractor* interactor,
                   const StudioOptions& options)
    : owner(owner), window(window), interactor(interactor), options(options) {
  window->SetNumberOfLayers(3);
  window->SetMultiSamples(0);
  scene->SetBackground(0.10, 0.11, 0.13);
  scene->SetBackground2(0.22, 0.24, 0.28);
  scene->GradientBackgroundOn();
  sphere->SetBackground(0.07, 0.08, 0.09);
  plane->SetBackground(0.13, 0.14, 0.16);
  overlay->SetLayer(2);
  overlay->InteractiveOff();
  highlightLayer->SetLayer(1);
  highlightLayer->InteractiveOff();
  highlightLayer->SetActiveCamera(scene->GetActiveCamera());
  for (vtkRenderer* renderer : {scene.Get(), sphere.Get(), plane.Get(), highlightLayer.Get(), overlay.Get()})
    window->AddRenderer(renderer);
  plane->GetActiveCamera()->ParallelProjectionOn();

  style->panOnly = plane;
  interactor->SetInteractorStyle(style);
  observe(style, vtkCommand::StartInteractionEvent, [this](vtkObject*, unsigned long, void*) {
    interacting = true;
    for (auto& [name, lod] : pointLods) lod.mapper->SetInputData(lod.coarse);
  });
  observe(style, vtkCommand::EndInteractionEvent, [this](vtkObject*, unsigned long, void*) {
    interacting = false;
    for (auto& [name, lod] : pointLods) lod.mapper->SetInputData(lod.full);
  });
  observe(interactor, vtkCommand::KeyPressEvent, [this](vtkObject*, unsigned long, void*) { onKey(); });
  // Passive: the camera style grabs the focus on a press, and the release must still reach picking.
  // (Clicks on the stage bar fall outside every view, so they pick nothing.)
  observe(interactor, vtkCommand::LeftButtonPressEvent, [this](vtkObject*, unsigned long, void*) { onLeftPress(); }, 0.0f,
          true);
  observe(interactor, vtkCommand::LeftButtonReleaseEvent, [this](vtkObject*, unsigned long, void*) { onLeftRelease(); },
          0.0f, true);

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
  sceneTitle = makeText(0.75, 0.8, 0.9);
  sphereTitle = makeText(0.75, 0.8, 0.9);
  planeTitle = makeText(0.75, 0.8, 0.9);
  statusText->GetTextProperty()->SetVerticalJustificationToTop();
  for (auto* title : {sceneTitle.Get(), sphereTitle.Get(), planeTitle.Get()}) {
    title->GetTextProperty()->SetVerticalJustificationToTop();
    title->GetTextProperty()->BoldOn();
  }
  for (auto* text : {statusText.Get(), infoText.Get(), progressText.Get(), sceneTitle.Get(), sphereTitle.Get(),
                     planeTitle.Get(), helpCommandsText.Get(), helpKeysText.Get()})
    overlay->AddViewProp(text);

  colorBar->SetNumberOfLabels(5);
  colorBar->SetLabelFormat("%.3g");
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

void Studio::Impl::open(Document opened) {
  if (worker.joinable()) throw CommandError("a run is in progress (Esc cancels it)");
  document = std::move(opened);
  if (document.input()) {
    displayOrigin = document.input()->origin;
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
  selection = {};
  selectedDirection = -1;
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
}

void Studio::Impl::takeResults() {
  const Pipeline* pipeline = document.pipeline();
  preprocessed = pipeline ? pipeline->preprocessResult() : nullptr;
  tiles = pipeline ? pipeline->tileResults() : nullptr;
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
  if (pipeColor == PipeColor::Run &&
      std::none_of(document.network().pipes.begin(), document.network().pipes.end(),
                   [](const Pipe& pipe) { return pipe.runId >= 0; }))
    pipeColor = PipeColor::Radius;
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
}

bool Studio::Impl::layerVisible(const std::string& name) const {
  const auto found = visibility.find(name);
  return found != visibility.end() && found->second && layers.count(name);
}

void Studio::Impl::setPointLayer(const std::string& name, const std::vector<Eigen::Vector3f>& positions,
                                 const std::vector<Rgb>& colors, double pointSize, bool defaultVisible) {
  PointLayerLod lod;
  lod.full = makePointSet(positions, colors);
  const std::size_t stride =
      std::max<std::size_t>(1, (positions.size() + options.interactivePoints - 1) / std::max<std::size_t>(1, options.interactivePoints));
  lod.coarse = stride > 1 ? subsamplePointSet(lod.full, stride) : lod.full;
  lod.mapper = vtkSmartPointer<vtkPolyDataMapper>::New();
  lod.mapper->SetInputData(interacting ? lod.coarse : lod.full);
  lod.mapper->SetScalarModeToUsePointData();
  lod.mapper->SetColorModeToDirectScalars();
  auto actor = vtkSmartPointer<vtkActor>::New();
  actor->SetMapper(lod.mapper);
  actor->GetProperty()->SetPointSize(static_cast<float>(pointSize));
  actor->GetProperty()->SetColor(kNeutral[0] / 255.0, kNeutral[1] / 255.0, kNeutral[2] / 255.0);
  actor->PickableOff();
  setLayer(name, scene, actor, defaultVisible);
  pointLods[name] = lod;
}

std::vector<Rgb> Studio::Impl::inputPointColors() {
  const PointCloud& cloud = *document.input();
  std::vector<Rgb> colors(cloud.size(), kNeutral);
  switch (pointColor) {
    case PointColor::Height: {
      const BoundingBox bounds = cloud.boundingBox();
      auto map = scalarMap(bounds.min.z(), bounds.max.z());
      for (std::size_t i = 0; i < cloud.size(); ++i) colors[i] = mapColor(map, cloud.worldPosition(i).z());
      break;
    }
    case PointColor::Intensity: {
      const auto [low, high] = std::minmax_element(cloud.intensities.begin(), cloud.intensities.end());
      auto map = scalarMap(*low, *high);
      for (std::size_t i = 0; i < cloud.size(); ++i) colors[i] = mapColor(map, cloud.intensities[i]);
      break;
    }
    case PointColor::Rgb:
      for (std::size_t i = 0; i < cloud.size(); ++i) colors[i] = {cloud.colors[i][0], cloud.colors[i][1], cloud.colors[i][2]};
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
  if (document.input()) {
    const PointCloud& cloud = *document.input();
    std::vector<Eigen::Vector3f> positions(cloud.size());
    const Eigen::Vector3f shift = (cloud.origin - displayOrigin).cast<float>();
    for (std::size_t i = 0; i < cloud.size(); ++i) positions[i] = cloud.positions[i] + shift;
    setPointLayer("input/points", positions, inputPointColors(), 2.0, true);
  } else {
    removeLayer("input/points");
  }

  if (!preprocessed) {
    for (const char* name : {"preprocess/points", "preprocess/normals", "preprocess/planes"}) removeLayer(name);
    return;
  }
  const PointCloud& kept = preprocessed->points;
  if (segmentCache.empty()) segmentCache = keptPointSegments();
  const Eigen::Vector3f shift = (kept.origin - displayOrigin).cast<float>();
  std::vector<Eigen::Vector3f> positions(kept.size());
  std::vector<Rgb> colors(kept.size());
  for (std::size_t i = 0; i < kept.size(); ++i) {
    positions[i] = kept.positions[i] + shift;
    colors[i] = categoryColor(segmentCache[i]);
  }
  setPointLayer("preprocess/points", positions, colors, 3.0, false);

  // Normal glyphs: a short line per point, for a bounded number of points.
  MeshBuilder normals;
  const double length = 3.0 * std::max(preprocessed->diagnostics.voxelSize, 0.005);
  const std::size_t stride = std::max<std::size_t>(1, kept.size() / 40000);
  for (std::size_t i = 0; i < kept.size() && kept.hasNormals(); i += stride) {
    const Eigen::Vector3d from = positions[i].cast<double>();
    normals.addPolyline({from, from + length * kept.normals[i].cast<double>()}, colors[i], static_cast<int>(i));
  }
  auto normalActor = meshActor(normals.build());
  normalActor->PickableOff();
  setLayer("preprocess/normals", scene, normalActor, false);

  const PointCloud& planes = preprocessed->planePoints;
  std::vector<Eigen::Vector3f> planePositions(planes.size());
  const Eigen::Vector3f planeShift = (planes.origin - displayOrigin).cast<float>();
  for (std::size_t i = 0; i < planes.size(); ++i) planePositions[i] = planes.positions[i] + planeShift;
  setPointLayer("preprocess/planes", planePositions, std::vector<Rgb>(planes.size(), Rgb{110, 110, 125}), 2.0, false);
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
  MeshBuilder pipes;
  for (const auto& pipe : network.pipes) {
    const Rgb color = pipeColor == PipeColor::Run          ? categoryColor(pipe.runId)
                      : pipeColor == PipeColor::Radius     ? mapColor(radiusMap, pipe.radius)
                      : pipeColor == PipeColor::Confidence ? mapColor(confidenceMap, pipe.confidence)
                                                           : Rgb{185, 190, 200};
    pipes.addTube({pipe.start - displayOrigin, pipe.end - displayOrigin}, pipe.radius, color, pipe.id);
  }
  setLayer("network/pipes", scene, meshActor(pipes.build()), true);

  MeshBuilder joints;
  for (const auto& joint : network.joints) {
    std::vector<Eigen::Vector3d> axis;
    for (const auto& point : joint.axis) axis.push_back(point - displayOrigin);
    // Slightly fatter than the pipes so the joint's colour shows where they overlap.
    joints.addTube(axis, joint.radius * 1.06, statusColor(joint.status), joint.id);
    // A tee's branch segment hides inside its main pipe: a collar around the main pipe shows it.
    const Pipe* main = joint.type == JointType::Tee && !joint.pipeIds.empty() ? network.findPipe(joint.pipeIds[0]) : nullptr;
    if (main) {
      const Eigen::Vector3d centre = joint.position() - displayOrigin;
      const Eigen::Vector3d along = main->direction() * (1.2 * joint.radius);
      joints.addTube({centre - along, centre + along}, main->radius * 1.1, statusColor(joint.status), joint.id);
    }
  }
  setLayer("network/joints", scene, meshActor(joints.build()), true);
}

void Studio::Impl::buildSelectionLayer() {
  MeshBuilder highlight;
  const PipeNetwork& network = document.network();
  if (selection.kind == Selection::Kind::Pipe) {
    const Pipe& pipe = *network.findPipe(selection.id);
    highlight.addTube({pipe.start - displayOrigin, pipe.end - displayOrigin}, pipe.radius * 1.12, kHighlight, pipe.id);
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
    for (const char* name : {"sphere/normals", "sphere/density", "sphere/directions"}) removeLayer(name);
    return;
  }
  // Normals at both their signs (the sign is arbitrary), coloured by segment.
  const PointCloud& kept = preprocessed->points;
  if (segmentCache.empty()) segmentCache = keptPointSegments();
  std::vector<Eigen::Vector3f> normalPoints;
  std::vector<Rgb> normalColors;
  const std::size_t stride = std::max<std::size_t>(1, kept.size() / 30000);
  for (std::size_t i = 0; i < kept.size() && kept.hasNormals(); i += stride) {
    const Rgb color = categoryColor(segmentCache[i]);
    normalPoints.push_back(kept.normals[i]);
    normalPoints.push_back(-kept.normals[i]);
    normalColors.insert(normalColors.end(), {color, color});
  }
  auto normalActor = meshActor(makePointSet(normalPoints, normalColors));
  normalActor->GetMapper()->SetScalarModeToUsePointData();
  normalActor->GetProperty()->SetPointSize(1.0f);
  normalActor->PickableOff();
  setLayer("sphere/normals", sphere, normalActor, true);

  // Direction samples (n_i × n_j) coloured by their density: counts in equal-area cells of the
  // upper hemisphere (uniform in z and in longitude).
  constexpr int kZCells = 40, kLongitudeCells = 120;
  std::vector<Eigen::Vector3f> samples;
  for (const auto& tile : *tiles)
    for (const auto& round : tile.rounds) samples.insert(samples.end(), round.directions.samples.begin(), round.directions.samples.end());
  auto cellOf = [&](const Eigen::Vector3f& s) {
    const int zCell = std::clamp(static_cast<int>(s.z() * kZCells), 0, kZCells - 1);
    const double longitude = std::atan2(s.y(), s.x()) + M_PI;
    const int longitudeCell = std::clamp(static_cast<int>(longitude / (2.0 * M_PI) * kLongitudeCells), 0, kLongitudeCells - 1);
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
    densityColors.push_back(mapColor(densityMap, std::log1p(static_cast<double>(counts[static_cast<std::size_t>(cellOf(samples[i]))]))));
  }
  auto densityActor = meshActor(makePointSet(densityPoints, densityColors));
  densityActor->GetMapper()->SetScalarModeToUsePointData();
  densityActor->GetProperty()->SetPointSize(2.0f);
  densityActor->PickableOff();
  setLayer("sphere/density", sphere, densityActor, true);

  // Principal directions: arrows with their great circles (where the stripe's normals lie).
  MeshBuilder arrows;
  for (std::size_t k = 0; k < directions.size(); ++k) {
    const bool selected = static_cast<int>(k) == selectedDirection;
    const Rgb color = selected ? kHighlight : categoryColor(static_cast<int>(k));
    const Eigen::Vector3d axis = direction(directions[k]).axis;
    arrows.addArrow(Eigen::Vector3d::Zero(), axis, 1.3, selected ? 0.022 : 0.013, color, static_cast<int>(k));
    arrows.addPolyline(circlePoints(Eigen::Vector3d::Zero(), axis, 1.005), color, static_cast<int>(k), true);
  }
  auto arrowActor = meshActor(arrows.build());
  arrowActor->GetProperty()->SetLineWidth(2.0f);
  setLayer("sphere/directions", sphere, arrowActor, true);
}

void Studio::Impl::buildPlaneLayers() {
  if (!preprocessed || !tiles || selectedDirection < 0) {
    for (const char* name : {"plane/points", "plane/candidates", "plane/circles"}) removeLayer(name);
    return;
  }
  const DirectionRef& ref = directions[static_cast<std::size_t>(selectedDirection)];
  const PrincipalDirection& chosen = direction(ref);
  const PlacementResult* placement = placementOf(ref);
  const PointCloud& kept = preprocessed->points;

  std::vector<Eigen::Vector3f> projected;
  std::vector<Rgb> pointColors;
  const PlacementResult::Projection* projection =
      ref.index < static_cast<int>(placement->projections.size()) ? &placement->projections[static_cast<std::size_t>(ref.index)]
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
  auto pointActor = meshActor(makePointSet(projected, pointColors));
  pointActor->GetMapper()->SetScalarModeToUsePointData();
  pointActor->GetProperty()->SetPointSize(2.0f);
  pointActor->PickableOff();
  setLayer("plane/points", plane, pointActor, true);

  std::vector<Eigen::Vector3f> candidates;
  std::vector<Rgb> candidateColors;
  if (projection)
    for (const auto& candidate : projection->candidates) {
      candidates.emplace_back(candidate.center.x(), candidate.center.y(), 0.001f);
      candidateColors.push_back(candidate.circle >= 0 ? categoryColor(candidate.circle) : Rgb{95, 95, 110});
    }
  auto candidateActor = meshActor(makePointSet(candidates, candidateColors));
  candidateActor->GetMapper()->SetScalarModeToUsePointData();
  candidateActor->GetProperty()->SetPointSize(3.0f);
  candidateActor->PickableOff();
  setLayer("plane/candidates", plane, candidateActor, true);

  MeshBuilder circles;
  for (std::size_t c = 0; c < placement->cylinders.size(); ++c) {
    const Cylinder& cylinder = placement->cylinders[c];
    if (cylinder.directionIndex != ref.index) continue;
    const Eigen::Vector3d center(cylinder.point.dot(u), cylinder.point.dot(v), 0.002);
    const bool selected = selection.kind == Selection::Kind::Pipe && pipeOfCylinder(ref, static_cast<int>(c)) == selection.id;
    circles.addPolyline(circlePoints(center, Eigen::Vector3d::UnitZ(), cylinder.radius),
                        selected ? kHighlight : Rgb{255, 60, 60}, static_cast<int>(c), true);
  }
  auto circleActor = meshActor(circles.build());
  circleActor->GetProperty()->SetLineWidth(2.5f);
  setLayer("plane/circles", plane, circleActor, true);
}

void Studio::Impl::updateColorBar() {
  vtkSmartPointer<vtkLookupTable> map;
  std::string title;
  if (layerVisible("input/points") && document.input()) {
    const PointCloud& cloud = *document.input();
    if (pointColor == PointColor::Height) {
      const BoundingBox bounds = cloud.boundingBox();
      map = scalarMap(bounds.min.z(), bounds.max.z());
      title = "height (m)";
    } else if (pointColor == PointColor::Intensity) {
      const auto [low, high] = std::minmax_element(cloud.intensities.begin(), cloud.intensities.end());
      map = scalarMap(*low, *high);
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
  }
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
  Rect sceneRect{0, bottom, split, 1}, sphereRect{split, (1 + bottom) / 2, 1, 1}, planeRect{split, bottom, 1, (1 + bottom) / 2};
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
  overlay->SetViewport(0, 0, 1, 1);

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
  for (auto* help : {helpCommandsText.Get(), helpKeysText.Get()}) help->GetTextProperty()->SetFontSize(static_cast<int>(11 * scale));
  helpCommandsText->SetPosition(pad * 2, height - pad * 6);
  helpKeysText->SetPosition(width * 0.55, height - pad * 6);

  const double barRight = textRect.x1 * width - pad;
  colorBar->GetPositionCoordinate()->SetValue(barRight - 90.0 * scale, textRect.y0 * height + 60.0 * scale);
  colorBar->GetPosition2Coordinate()->SetValue(60.0 * scale, std::min(260.0 * scale, (textRect.y1 - textRect.y0) * height * 0.5));
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
  camera->SetFocalPoint(0, 0, 0);
  camera->SetPosition(0.55, 1.0, 0.8);
  camera->SetViewUp(0, 0, 1);
  scene->ResetCamera();
  scene->ResetCameraClippingRange();
}

void Studio::Impl::resetSphereCamera() {
  vtkCamera* camera = sphere->GetActiveCamera();
  camera->SetFocalPoint(0, 0, 0);
  camera->SetPosition(2.4, -3.6, 2.4);
  camera->SetViewUp(0, 0, 1);
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
      (Eigen::Vector3d(position[0], position[1], position[2]) - Eigen::Vector3d(focal[0], focal[1], focal[2])).normalized();
  const Eigen::Vector3d target = world - displayOrigin;
  const double distance = std::max(size, 0.05) * 1.2 / std::tan(camera->GetViewAngle() * M_PI / 360.0);
  const Eigen::Vector3d eye = target + distance * viewDirection;
  camera->SetFocalPoint(target.data());
  camera->SetPosition(eye.data());
  scene->ResetCameraClippingRange();
}

std::vector<StageState> Studio::Impl::stageStates() const {
  std::vector<StageState> states;
  const Pipeline* pipeline = document.pipeline();
  for (Stage stage : kAllStages) {
    const auto index = static_cast<std::size_t>(stage);
    if (worker.joinable()) {
      states.push_back(freshBeforeRun[index]                                       ? StageState::Fresh
                       : static_cast<int>(stage) <= static_cast<int>(runLast)       ? StageState::Running
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

std::string Studio::Impl::selectionInfo() const {
  const PipeNetwork& network = document.network();
  std::ostringstream info;
  info.precision(3);
  if (selection.kind == Selection::Kind::Pipe) {
    const Pipe& pipe = *network.findPipe(selection.id);
    info << "pipe " << pipe.id << "  radius " << pipe.radius * 1000.0 << " mm  length " << pipe.length()
         << " m\nconfidence " << pipe.confidence << "  fit RMS " << pipe.fitRms * 1000.0 << " mm  inliers "
         << pipe.inlierCount << "  run " << (pipe.runId >= 0 ? std::to_string(pipe.runId) : "-") << "  "
         << toString(pipe.status);
  } else if (selection.kind == Selection::Kind::Joint) {
    const Joint& joint = *network.findJoint(selection.id);
    info << "joint " << joint.id << "  " << toString(joint.type) << "  " << toString(joint.status) << "  radius "
         << joint.radius * 1000.0 << " mm  length " << joint.length() << " m";
    if (joint.type == JointType::Elbow) info << "  bend radius " << joint.bendRadius << " m";
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
    info << "direction " << selectedDirection << " (tile " << (*tiles)[static_cast<std::size_t>(ref.tile)].tileId
         << ", round " << ref.round << ")  axis (" << chosen.axis.x() << ", " << chosen.axis.y() << ", " << chosen.axis.z()
         << ")  support " << chosen.support * 100.0 << " %  stripe " << chosen.stripe.size() << " points  "
         << cylinders << " cylinders";
  }
  return info.str();
}

void Studio::Impl::updateOverlays() {
  const Pipeline* pipeline = document.pipeline();
  const PipeNetwork& network = document.network();
  std::ostringstream status;
  if (document.empty()) {
    status << "No file open: drop a scan or a network onto the window";
  } else {
    status << document.path().filename().string();
    if (document.input()) status << "  " << document.input()->size() << " points";
    status << "\n" << network.pipes.size() << " pipes  " << network.joints.size() << " joints  " << network.runs.size()
           << " runs";
    if (pipeline) status << "  " << directions.size() << " directions";
  }
  if (!message.empty()) status << "\n" << message;
  statusText->SetInput(status.str().c_str());
  infoText->SetInput(selectionInfo().c_str());

  sceneTitle->SetInput(("3-D scene  [points: " + nameOf(kPointColors, pointColor) + ", pipes: " + nameOf(kPipeColors, pipeColor) + "]").c_str());
  sphereTitle->SetInput("Gaussian sphere");
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
  for (const auto& entry : layers) keyHelp += std::string("  [") + (layerVisible(entry.first) ? "x" : " ") + "] " + entry.first + "\n";
  helpCommandsText->SetInput(commandHelp.c_str());
  helpKeysText->SetInput(keyHelp.c_str());
  helpCommandsText->SetVisibility(helpShown);
  helpKeysText->SetVisibility(helpShown);

  if (document.hasPipeline() && stageBar->enabled()) stageBar->setStates(stageStates());
  for (auto& line : jointLegend)
    line->SetVisibility(!network.joints.empty() && layerVisible("network/joints") &&
                        (viewMode == ViewMode::All || viewMode == ViewMode::Scene));
  updateColorBar();
}

// ---------------------------------------------------------------------------------------------
// Running stages

void Studio::Impl::startRun(Stage last) {
  if (worker.joinable()) throw CommandError("a run is in progress (Esc cancels it)");
  Pipeline* pipeline = document.pipeline();
  if (!pipeline) throw CommandError("stages run on scans; this document is a network");
  if (!options.backgroundStages) {
    try {
      pipeline->run(Progress::none(), last);
    } catch (const Cancelled&) {
    }
    finishRun();
    return;
  }
  for (Stage stage : kAllStages) freshBeforeRun[static_cast<std::size_t>(stage)] = pipeline->isFresh(stage);
  runLast = last;
  finished = false;
  runError = nullptr;
  {
    std::lock_guard<std::mutex> lock(progressMutex);
    progressTask = stageName(last);
    progressFraction = 0.0;
  }
  runProgress = std::make_unique<Progress>([this](const std::string& task, double fraction) {
    std::lock_guard<std::mutex> lock(progressMutex);
    progressTask = task;
    progressFraction = fraction;
    progressChanged = true;
  });
  worker = std::thread([this, pipeline, last] {
    try {
      pipeline->run(*runProgress, last);
    } catch (...) {
      runError = std::current_exception();
    }
    finished = true;
  });
  updateOverlays();
}

void Studio::Impl::finishRun() {
  document.refreshNetwork();
  takeResults();
  rebuildAll();
  if (layers.count("plane/points")) resetPlaneCamera();
}

bool Studio::Impl::poll() {
  bool changed = progressChanged.exchange(false);
  if (worker.joinable() && finished) {
    worker.join();
    try {
      if (runError) std::rethrow_exception(runError);
      message = "finished";
    } catch (const Cancelled&) {
      message = "cancelled: the stages that had finished are kept";
    } catch (const std::exception& error) {
      message = std::string("run failed: ") + error.what();
    }
    finishRun();
    if (options.runFinished) options.runFinished(message);
    changed = true;
  }
  if (changed) updateOverlays();
  return changed;
}

// ---------------------------------------------------------------------------------------------
// Interaction

void Studio::Impl::onKey() {
  std::string key = interactor->GetKeySym() ? interactor->GetKeySym() : "";
  std::transform(key.begin(), key.end(), key.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  for (const auto& [boundKey, line] : keyBindings) {
    if (boundKey != key) continue;
    try {
      message = commands.run(line);
    } catch (const std::exception& error) {
      message = error.what();
    }
    updateOverlays();
    return;
  }
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
  const bool doubleClick = now - lastClickTime < std::chrono::milliseconds(400) && std::abs(position[0] - lastClickX) < 6 &&
                           std::abs(position[1] - lastClickY) < 6;
  lastClickTime = now;
  lastClickX = position[0];
  lastClickY = position[1];
  pick(position[0], position[1], doubleClick);
  updateOverlays();
}

void Studio::Impl::pick(int x, int y, bool doubleClick) {
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
      const int element = pickedElement(scene, {"network/joints", "network/pipes"}, layer);
      if (element < 0) {
        message = commands.run("select none");
        return;
      }
      const std::string kind = layer == "network/joints" ? "joint" : "pipe";
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

// ---------------------------------------------------------------------------------------------
// Commands

void Studio::Impl::registerCommands() {
  commands.add("help", "", "show or hide the list of commands and keys", [this](const std::vector<std::string>& args) {
    expectArguments(args, 0, 0, "help");
    helpShown = !helpShown;
    updateOverlays();
    return std::string();
  });

  commands.add("view", "all|scene|sphere|plane", "show the three views, or one of them filling the window",
               [this](const std::vector<std::string>& args) {
                 expectArguments(args, 1, 1, "view all|scene|sphere|plane");
                 viewMode = parseName(kViewModes, args[0], "view");
                 layout();
                 return "view " + args[0];
               });

  commands.add("select", "pipe ID | joint ID | direction N|next|previous | none",
               "select an element (highlighted, described bottom left) or a principal direction (the plane view follows)",
               [this](const std::vector<std::string>& args) {
                 expectArguments(args, 1, 2, "select pipe ID | joint ID | direction N | none");
                 if (args[0] == "none") {
                   selection = {};
                 } else {
                   expectArguments(args, 2, 2, "select pipe ID | joint ID | direction N|next|previous | none");
                   const int directionCount = static_cast<int>(directions.size());
                   const bool step = args[0] == "direction" && (args[1] == "next" || args[1] == "previous");
                   if (step && directionCount == 0) throw CommandError("no directions yet: run the directions stage");
                   const int id = !step                 ? parseInt(args[1], "the id")
                                  : args[1] == "next"   ? (selectedDirection + 1) % directionCount
                                                        : (selectedDirection + directionCount - 1) % directionCount;
                   if (args[0] == "pipe") {
                     if (!document.network().findPipe(id)) throw CommandError("no pipe " + args[1]);
                     selection = {Selection::Kind::Pipe, id};
                   } else if (args[0] == "joint") {
                     if (!document.network().findJoint(id)) throw CommandError("no joint " + args[1]);
                     selection = {Selection::Kind::Joint, id};
                   } else if (args[0] == "direction") {
                     if (id < 0 || id >= static_cast<int>(directions.size()))
                       throw CommandError("no direction " + args[1] + " (there are " + std::to_string(directions.size()) + ")");
                     selectedDirection = id;
                     buildSphereLayers();
                   } else {
                     throw CommandError("usage: select pipe ID | joint ID | direction N | none");
                   }
                 }
                 buildSelectionLayer();
                 buildPlaneLayers();
                 if (args[0] == "direction") resetPlaneCamera();
                 updateOverlays();
                 return args[0] == "none"        ? std::string("selection cleared")
                        : args[0] == "direction" ? "selected direction " + std::to_string(selectedDirection)
                                                 : "selected " + args[0] + " " + args[1];
               });

  commands.add("fly", "", "move the 3-D camera to the selected pipe or joint", [this](const std::vector<std::string>& args) {
    expectArguments(args, 0, 0, "fly");
    const PipeNetwork& network = document.network();
    if (selection.kind == Selection::Kind::Pipe) {
      const Pipe& pipe = *network.findPipe(selection.id);
      flyTo(0.5 * (pipe.start + pipe.end), std::max(pipe.length() / 2.0, 4.0 * pipe.radius));
    } else if (selection.kind == Selection::Kind::Joint) {
      const Joint& joint = *network.findJoint(selection.id);
      flyTo(joint.position(), std::max(joint.length(), 12.0 * joint.radius));
    } else {
      throw CommandError("nothing selected to fly to");
    }
    return std::string("camera on the selection");
  });

  commands.add("color", "points height|intensity|rgb|segment|element|qa | pipes run|radius|confidence|plain",
               "colour the input points or the pipes", [this](const std::vector<std::string>& args) {
                 expectArguments(args, 2, 2, "color points MODE | color pipes MODE");
                 if (args[0] == "points") {
                   const PointColor mode = parseName(kPointColors, args[1], "point colour");
                   const PointCloud* cloud = document.input().get();
                   if (!cloud) throw CommandError("no points: this document is a network");
                   if (mode == PointColor::Intensity && !cloud->hasIntensity()) throw CommandError("the scan has no intensity");
                   if (mode == PointColor::Rgb && !cloud->hasColors()) throw CommandError("the scan has no colours");
                   if (mode == PointColor::Segment && directions.empty())
                     throw CommandError("no segments yet: run the directions stage");
                   pointColor = mode;
                   buildPointLayers();
                 } else if (args[0] == "pipes") {
                   pipeColor = parseName(kPipeColors, args[1], "pipe colour");
                   buildNetworkLayers();
                 } else {
                   throw CommandError("usage: color points MODE | color pipes MODE");
                 }
                 updateOverlays();
                 return args[0] + " coloured by " + args[1];
               });

  commands.add("layer", "NAME on|off|toggle", "show or hide a layer (layers lists them)",
               [this](const std::vector<std::string>& args) {
                 expectArguments(args, 2, 2, "layer NAME on|off|toggle");
                 if (!layers.count(args[0])) throw CommandError("no layer '" + args[0] + "' (layers lists them)");
                 bool& shown = visibility[args[0]];
                 if (args[1] == "on") shown = true;
                 else if (args[1] == "off") shown = false;
                 else if (args[1] == "toggle") shown = !shown;
                 else throw CommandError("usage: layer NAME on|off|toggle");
                 layers[args[0]].prop->SetVisibility(shown);
                 updateOverlays();
                 return args[0] + (shown ? " on" : " off");
               });

  commands.add("layers", "", "list the layers and whether they are shown", [this](const std::vector<std::string>& args) {
    expectArguments(args, 0, 0, "layers");
    std::string list;
    for (const auto& [name, layer] : layers) list += (list.empty() ? "" : "  ") + name + (visibility[name] ? "" : " (off)");
    return list;
  });

  commands.add("run", "[STAGE]", "run the stale stages up to STAGE (default: all)", [this](const std::vector<std::string>& args) {
    expectArguments(args, 0, 1, "run [STAGE]");
    Stage last = kAllStages.back();
    if (!args.empty()) {
      const auto stage = stageFromName(args[0]);
      if (!stage) throw CommandError("unknown stage '" + args[0] + "'");
      last = *stage;
    }
    startRun(last);
    return std::string(options.backgroundStages ? "running" : "ran") + " up to " + stageName(last);
  });

  commands.add("rerun", "STAGE [section.key=value ...]",
               "set parameters, mark STAGE and the later stages stale and run them all",
               [this](const std::vector<std::string>& args) {
                 if (args.empty()) throw CommandError("usage: rerun STAGE [section.key=value ...]");
                 const auto stage = stageFromName(args[0]);
                 if (!stage) throw CommandError("unknown stage '" + args[0] + "'");
                 Pipeline* pipeline = document.pipeline();
                 if (!pipeline) throw CommandError("stages run on scans; this document is a network");
                 if (worker.joinable()) throw CommandError("a run is in progress (Esc cancels it)");
                 PipelineParams params = pipeline->params();
                 for (std::size_t i = 1; i < args.size(); ++i) {
                   try {
                     setParam(params, args[i]);
                   } catch (const std::exception& error) {
                     throw CommandError(error.what());
                   }
                 }
                 pipeline->setParams(params);
                 pipeline->invalidate(*stage);
                 startRun(kAllStages.back());
                 return "rerunning from " + args[0];
               });

  commands.add("set", "section.key=value ...", "set parameters (the affected stages become stale)",
               [this](const std::vector<std::string>& args) {
                 if (args.empty()) throw CommandError("usage: set section.key=value ...");
                 Pipeline* pipeline = document.pipeline();
                 if (!pipeline) throw CommandError("parameters belong to scans; this document is a network");
                 if (worker.joinable()) throw CommandError("a run is in progress (Esc cancels it)");
                 PipelineParams params = pipeline->params();
                 for (const auto& assignment : args) {
                   try {
                     setParam(params, assignment);
                   } catch (const std::exception& error) {
                     throw CommandError(error.what());
                   }
                 }
                 pipeline->setParams(params);
                 selectStage(selectedStage);
                 updateOverlays();
                 return std::string("parameters set");
               });

  commands.add("stage", "STAGE", "choose the stage the slider edits", [this](const std::vector<std::string>& args) {
    expectArguments(args, 1, 1, "stage STAGE");
    const auto stage = stageFromName(args[0]);
    if (!stage) throw CommandError("unknown stage '" + args[0] + "'");
    if (worker.joinable()) throw CommandError("a run is in progress (Esc cancels it)");
    selectStage(*stage);
    const StageParameter* parameter = mainParameter(*stage);
    return "stage " + args[0] + (parameter ? ": slider edits " + parameter->key : std::string());
  });

  commands.add("cancel", "", "stop the running stages at their next safe point", [this](const std::vector<std::string>& args) {
    expectArguments(args, 0, 0, "cancel");
    if (!worker.joinable()) return std::string("nothing is running");
    runProgress->cancel();
    return std::string("cancelling");
  });

  commands.add("camera", "reset | azimuth DEG | elevation DEG | zoom FACTOR", "move the camera of the 3-D scene",
               [this](const std::vector<std::string>& args) {
                 expectArguments(args, 1, 2, "camera reset | azimuth DEG | elevation DEG | zoom FACTOR");
                 vtkCamera* camera = scene->GetActiveCamera();
                 if (args[0] == "reset") {
                   expectArguments(args, 1, 1, "camera reset");
                   resetSceneCamera();
                   resetSphereCamera();
                   resetPlaneCamera();
                   return std::string("cameras reset");
                 }
                 expectArguments(args, 2, 2, "camera azimuth DEG | elevation DEG | zoom FACTOR");
                 const double value = parseDouble(args[1], args[0].c_str());
                 if (args[0] == "azimuth") camera->Azimuth(value);
                 else if (args[0] == "elevation") {
                   camera->Elevation(value);
                   camera->OrthogonalizeViewUp();
                 } else if (args[0] == "zoom") {
                   if (!(value > 0.0)) throw CommandError("zoom needs a positive factor");
                   camera->Dolly(value);
                 } else {
                   throw CommandError("usage: camera reset | azimuth DEG | elevation DEG | zoom FACTOR");
                 }
                 scene->ResetCameraClippingRange();
                 return "camera " + args[0] + " " + args[1];
               });

  commands.add("joint", "ID accept|reject|propose", "set a joint's review status", [this](const std::vector<std::string>& args) {
    expectArguments(args, 2, 2, "joint ID accept|reject|propose");
    Joint* joint = document.network().findJoint(parseInt(args[0], "the joint id"));
    if (!joint) throw CommandError("no joint " + args[0]);
    if (args[1] == "accept") joint->status = JointStatus::Accepted;
    else if (args[1] == "reject") joint->status = JointStatus::Rejected;
    else if (args[1] == "propose") joint->status = JointStatus::Proposed;
    else throw CommandError("usage: joint ID accept|reject|propose");
    buildNetworkLayers();
    updateOverlays();
    return "joint " + args[0] + " " + toString(joint->status);
  });

  commands.add("widgets", "on|off", "show or hide the stage bar and the parameter slider",
               [this](const std::vector<std::string>& args) {
                 expectArguments(args, 1, 1, "widgets on|off");
                 if (args[0] != "on" && args[0] != "off") throw CommandError("usage: widgets on|off");
                 widgetsShown = args[0] == "on";
                 stageBar->setEnabled(widgetsShown && document.hasPipeline());
                 layout();
                 updateOverlays();
                 return "widgets " + args[0];
               });

  commands.add("screenshot", "FILE.png", "write the window as a PNG image", [this](const std::vector<std::string>& args) {
    expectArguments(args, 1, 1, "screenshot FILE.png");
    owner.render();
    vtkNew<vtkWindowToImageFilter> capture;
    capture->SetInput(window);
    capture->ReadFrontBufferOff();
    capture->Update();
    vtkNew<vtkPNGWriter> writer;
    writer->SetFileName(args[0].c_str());
    writer->SetInputConnection(capture->GetOutputPort());
    writer->Write();
    if (writer->GetErrorCode() != 0) throw CommandError(args[0] + ": cannot write the image");
    return "wrote " + args[0];
  });

  commands.add("click", "X Y [double]",
               "click at window pixel (X, Y), origin bottom left: picks like the mouse (double: also flies)",
               [this](const std::vector<std::string>& args) {
                 expectArguments(args, 2, 3, "click X Y [double]");
                 if (args.size() == 3 && args[2] != "double") throw CommandError("usage: click X Y [double]");
                 owner.render();  // Picking needs the current layout and camera.
                 message.clear();
                 pick(parseInt(args[0], "X"), parseInt(args[1], "Y"), args.size() == 3);
                 return message.empty() ? std::string("nothing there") : message;
               });

  commands.add("frames", "N",
               "time N frames turning the 3-D camera once around, drawn as while dragging and as when still",
               [this](const std::vector<std::string>& args) {
                 expectArguments(args, 1, 1, "frames N");
                 const int count = parseInt(args[0], "the frame count");
                 if (count < 1) throw CommandError("frames needs at least 1 frame");
                 vtkNew<vtkCamera> saved;
                 saved->DeepCopy(scene->GetActiveCamera());
                 auto timeFrames = [&](bool moving) {
                   interacting = moving;
                   for (auto& [name, lod] : pointLods) lod.mapper->SetInputData(moving ? lod.coarse : lod.full);
                   owner.render();  // Uploads the points; not timed.
                   const auto start = std::chrono::steady_clock::now();
                   for (int i = 0; i < count; ++i) {
                     scene->GetActiveCamera()->Azimuth(360.0 / count);
                     window->Render();
                   }
                   const std::chrono::duration<double, std::milli> elapsed = std::chrono::steady_clock::now() - start;
                   vtkIdType points = 0;
                   for (auto& [name, lod] : pointLods)
                     if (layerVisible(name)) points += (moving ? lod.coarse : lod.full)->GetNumberOfPoints();
                   return format("%.1f ms/frame", elapsed.count() / count) + " (" + std::to_string(points) + " points)";
                 };
                 const std::string moving = timeFrames(true);
                 const std::string still = timeFrames(false);
                 scene->GetActiveCamera()->DeepCopy(saved);
                 scene->ResetCameraClippingRange();
                 return "moving " + moving + ", still " + still;
               });

  commands.add("open", "FILE", "open a scan or a network (.json) in place of the current document",
               [this](const std::vector<std::string>& args) {
                 if (args.empty()) throw CommandError("usage: open FILE");
                 std::string path = args[0];
                 for (std::size_t i = 1; i < args.size(); ++i) path += " " + args[i];  // Names with blanks.
                 try {
                   open(Document::open(path));
                 } catch (const InputError& error) {
                   throw CommandError(error.what());
                 }
                 return "opened " + path;
               });

  commands.add("quit", "", "close the studio", [this](const std::vector<std::string>& args) {
    expectArguments(args, 0, 0, "quit");
    quit = true;
    return std::string();
  });

  keyBindings = {{"h", "help"},
                 {"1", "view all"},
                 {"2", "view scene"},
                 {"3", "view sphere"},
                 {"4", "view plane"},
                 {"return", "run"},
                 {"escape", "cancel"},
                 {"home", "camera reset"},
                 {"right", "select direction next"},
                 {"left", "select direction previous"},
                 {"f", "fly"},
                 {"c", "color points height"},
                 {"q", "color points qa"},
                 {"e", "color points element"},
                 {"s", "color points segment"},
                 {"i", "color points intensity"},
                 {"p", "color pipes run"},
                 {"r", "color pipes radius"},
                 {"k", "color pipes confidence"},
                 {"g", "layer input/points toggle"},
                 {"o", "layer preprocess/points toggle"},
                 {"n", "layer preprocess/normals toggle"},
                 {"t", "layer network/pipes toggle"},
                 {"j", "layer network/joints toggle"},
                 {"a", "rerun directions"},
                 {"l", "rerun placement"},
                 {"x", "rerun extents"}};
}

std::vector<std::string> Studio::Impl::keyHelpLines() const {
  std::vector<std::string> lines;
  for (const auto& [key, line] : keyBindings) {
    std::string shown = key;
    shown[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(shown[0])));
    lines.push_back(shown + std::string(shown.size() < 8 ? 8 - shown.size() : 1, ' ') + line);
  }
  lines.push_back("click   select a pipe, joint, direction or circle");
  lines.push_back("double-click  fly to the clicked pipe or joint");
  return lines;
}

// ---------------------------------------------------------------------------------------------
// Studio

Studio::Studio(vtkRenderWindow* window, vtkRenderWindowInteractor* interactor, const StudioOptions& options)
    : impl_(std::make_unique<Impl>(*this, window, interactor, options)) {}

Studio::~Studio() = default;

void Studio::open(Document document) { impl_->open(std::move(document)); }

void Studio::open(const std::filesystem::path& path) { impl_->open(Document::open(path)); }

const Document& Studio::document() const { return impl_->document; }

std::string Studio::command(const std::string& line) {
  impl_->message = impl_->commands.run(line);
  impl_->updateOverlays();
  return impl_->message;
}

void Studio::runScript(const std::filesystem::path& path) {
  impl_->message = impl_->commands.runScript(path);
  impl_->updateOverlays();
}

const CommandRegistry& Studio::commands() const { return impl_->commands; }

std::vector<std::string> Studio::keyHelpLines() const { return impl_->keyHelpLines(); }

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
  const auto& path = impl_->document.path();
  return path.empty() ? std::string("PipeRun Studio") : "PipeRun Studio - " + path.filename().string();
}

bool Studio::quitRequested() const { return impl_->quit; }

const std::string& Studio::message() const { return impl_->message; }

}  // namespace piperun::ui
