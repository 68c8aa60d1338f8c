#pragma once
// Inside ui::Studio: the state behind the public class, shared by studio.cpp (document, views,
// overlays, runs, interaction), studio_layers.cpp (building the layers) and studio_commands.cpp.

#include "piperun/ui/studio.h"

#include "palette.h"
#include "point_budget.h"
#include "point_measures.h"
#include "stage_bar.h"

#include "piperun/edit/command_interpreter.h"
#include "piperun/edit/review_queue.h"
#include "piperun/params.h"

#include <vtkBoxWidget2.h>
#include <vtkHandleWidget.h>
#include <vtkInteractorStyleTrackballCamera.h>
#include <vtkNew.h>
#include <vtkPolyDataMapper.h>
#include <vtkRenderer.h>
#include <vtkScalarBarActor.h>
#include <vtkSmartPointer.h>
#include <vtkTextActor.h>

#include <Eigen/Core>

#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <mutex>
#include <optional>
#include <utility>
#include <string>
#include <thread>
#include <vector>

class vtkActor;
class vtkPolyData;

namespace piperun::ui {

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
  void OnLeftButtonDown() override;
};

enum class ViewMode { All, Scene, Sphere, Plane };
enum class PointColor { Height, Intensity, Rgb, Segment, Element, Qa };
enum class PipeColor { Run, Radius, Confidence, Plain };

inline const std::map<std::string, ViewMode> kViewModes{
    {"all", ViewMode::All}, {"scene", ViewMode::Scene}, {"sphere", ViewMode::Sphere}, {"plane", ViewMode::Plane}};
inline const std::map<std::string, PointColor> kPointColors{
    {"height", PointColor::Height},   {"intensity", PointColor::Intensity}, {"rgb", PointColor::Rgb},
    {"segment", PointColor::Segment}, {"element", PointColor::Element},     {"qa", PointColor::Qa}};
inline const std::map<std::string, PipeColor> kPipeColors{{"run", PipeColor::Run},
                                                          {"radius", PipeColor::Radius},
                                                          {"confidence", PipeColor::Confidence},
                                                          {"plain", PipeColor::Plain}};

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

inline int parseInt(const std::string& word, const char* what) {
  try {
    std::size_t used = 0;
    const int value = std::stoi(word, &used);
    if (used == word.size()) return value;
  } catch (const std::exception&) {
  }
  throw CommandError(std::string("expected ") + what + " as an integer, got '" + word + "'");
}

inline double parseDouble(const std::string& word, const char* what) {
  try {
    std::size_t used = 0;
    const double value = std::stod(word, &used);
    if (used == word.size()) return value;
  } catch (const std::exception&) {
  }
  throw CommandError(std::string("expected ") + what + " as a number, got '" + word + "'");
}

inline void expectArguments(const std::vector<std::string>& args, std::size_t minimum, std::size_t maximum,
                            const char* usage) {
  if (args.size() < minimum || args.size() > maximum) throw CommandError(std::string("usage: ") + usage);
}

inline std::string format(const char* pattern, double value) {
  char text[64];
  std::snprintf(text, sizeof text, pattern, value);
  return text;
}

/// "X Y Z" at full precision, as the edit commands take a point.
inline std::string formatPoint(const Eigen::Vector3d& point) {
  return format("%.17g", point.x()) + " " + format("%.17g", point.y()) + " " + format("%.17g", point.z());
}

/// The region between two heights along `up` (m; either may be infinite), open sideways.
inline BoundingBox heightRange(double low, double high, UpAxis up) {
  constexpr double kOpen = std::numeric_limits<double>::infinity();
  BoundingBox range;
  range.min = Eigen::Vector3d::Constant(-kOpen);
  range.max = Eigen::Vector3d::Constant(kOpen);
  const int k = upIndex(up);
  range.min[k] = upSign(up) > 0.0 ? low : -high;
  range.max[k] = upSign(up) > 0.0 ? high : -low;
  return range;
}

/// The heights along `up` that `range` (a heightRange, or any box) spans.
inline std::pair<double, double> heightLimits(const BoundingBox& range, UpAxis up) {
  const int k = upIndex(up);
  return upSign(up) > 0.0 ? std::make_pair(range.min[k], range.max[k]) : std::make_pair(-range.max[k], -range.min[k]);
}

/// A principal direction of one tile's round, numbered across all tiles for the views.
struct DirectionRef {
  int tile = 0;  ///< Index into the pipeline's tile results.
  int round = 0;
  int index = 0;  ///< Index into the round's DirectionsResult::directions.
};

struct Selection {
  enum class Kind { None, Pipe, Joint } kind = Kind::None;
  int id = 0;
  int secondPipe = -1;  ///< A second selected pipe (Shift+click), for merge and join; -1 when none.
};

/// A scene layer's points filed by cell, so that a view can choose the share of them it asks for
/// (pointsToDraw): the subsample drawn while the camera moves, and, over the point budget, the
/// points drawn when it is still.
struct FiledPoints {
  /// The scan itself when the layer draws its points where they lie (the input points: the display
  /// origin is the scan's origin), so that a site's positions are not held twice; else null.
  std::shared_ptr<const PointCloud> source;
  std::vector<Eigen::Vector3f> positions;  ///< The layer's own positions when there is no source.
  std::vector<Rgb> colors;
  PointCells cells;
  const std::vector<Eigen::Vector3f>& points() const { return source ? source->positions : positions; }
};

/// A camera's position, focal point, view-up, angle, parallel scale and projection, and the view's
/// aspect: what decides which of a layer's points are in view.
using ViewKey = std::array<double, 12>;

/// A points layer drawn whole when the camera is still and as a subsample while it moves; a scene
/// layer of more points than the budget, when still, as the points its view asks for.
struct PointLayerLod {
  double pointSize = 1.0;  ///< Pixels (screen units), as the layer asks; the scene's follow scenePointSize.
  vtkSmartPointer<vtkPolyDataMapper> mapper;
  vtkSmartPointer<vtkPolyData> full;    ///< Drawn when still: every point, or those chosen by view (chosenBudget).
  vtkSmartPointer<vtkPolyData> coarse;  ///< Drawn while the camera moves.
  /// Scene layers of more points than the moving subsample; null for the others. Rebuilding the
  /// layer with the same points (another colour mode) takes their filing over.
  std::shared_ptr<FiledPoints> filed;
  /// The layer's share of pointBudget that `full` was chosen for by view (the shown layers share
  /// it when they have more points together); 0: `full` holds every point.
  std::size_t chosenBudget = 0;
  std::optional<ViewKey> chosenFor;  ///< The view `full` was chosen for (chosenBudget > 0).
};

struct Layer {
  vtkRenderer* renderer = nullptr;
  vtkSmartPointer<vtkProp> prop;
};

/// An actor drawing a mesh from MeshBuilder with its per-cell colours.
vtkSmartPointer<vtkActor> meshActor(vtkPolyData* polyData);
/// A text overlay in the studio's font.
vtkSmartPointer<vtkTextActor> makeText(double r, double g, double b);

/// Points farther than this from every surface are not coloured by the QA map (m).
inline constexpr double kQaReach = 0.02;
/// Stray points: cells of this many point spacings (estimatePointSpacing), and fewer neighbours
/// than this in a cell's 3 x 3 x 3 block.
inline constexpr double kStrayCellSpacings = 5.0;
inline constexpr int kStrayNeighbours = 2;
/// While the camera moves, the scene's subsample covers its view widened this many times (what a
/// drag may turn to), no wider than kWidestViewAngle (degrees).
inline constexpr double kMovingViewWidening = 1.5;
inline constexpr double kWidestViewAngle = 150.0;
/// Scans of more points than this open with the scene's points at 1 pixel, not 2.
inline constexpr std::size_t kDenseScanPoints = 4'000'000;
/// Most labels on the colour bar (round values: roundTicks).
inline constexpr int kColorBarLabels = 6;

struct Studio::Impl {
  Impl(Studio& owner, vtkRenderWindow* window, vtkRenderWindowInteractor* interactor, const StudioOptions& options);
  ~Impl();

  // Document and derived data.
  void open(Document opened);
  void takeResults();
  void rebuildAll();
  const DirectionsResult* directionsOf(const DirectionRef& ref) const;
  const PlacementResult* placementOf(const DirectionRef& ref) const;
  /// Round `round` of tile `tile` with its sphere samples and circle candidates (without them when
  /// the tiles are stale, made from a preprocessing since replaced).
  const TileRound& viewRound(int tile, int round) const;
  const PrincipalDirection& direction(const DirectionRef& ref) const;
  std::vector<int> keptPointSegments() const;
  int pipeOfCylinder(const DirectionRef& ref, int cylinder) const;
  /// The selected direction if one of its circles became pipe `pipeId`, else the first direction
  /// with such a circle, else -1.
  int directionShowingPipe(int pipeId) const;
  /// The tile whose Gaussian sphere the sphere view shows (the selected direction's); -1 when the
  /// scan is one tile and the sphere shows all of it.
  int sphereTile() const;
  /// The id a tile (an index into `tiles`) goes by in the views: the preprocess stage's.
  int tileIdOf(int tile) const;
  /// That tile's points and cube (the preprocess stage's); null when the sphere shows the whole scan.
  const Tile* sphereTilePoints() const;
  /// That tile's cube cut to the points' bounds (world, m); none when the sphere shows the whole scan.
  std::optional<BoundingBox> sphereTileCube() const;
  /// The first direction of the tile `word` names (its id, or next/previous from the selected
  /// direction's tile, skipping tiles with none); throws naming what is missing.
  int directionOfTile(const std::string& word) const;

  // Layers.
  void setLayer(const std::string& name, vtkRenderer* renderer, vtkSmartPointer<vtkProp> prop, bool defaultVisible);
  void removeLayer(const std::string& name);
  bool layerVisible(const std::string& name) const;
  /// Draws every point layer whole or as its subsample (coarsePoints). Going coarse, the scene's
  /// filed layers take the subsample of the camera's view widened by kMovingViewWidening.
  void setCoarsePoints(bool coarse);
  /// The scene's view for choosing points (pointsToDraw): the sides of the camera's frustum with its
  /// view angle (or parallel scale) times `widening`, the clip's faces, the eye.
  ViewVolume sceneViewVolume(double widening) const;
  /// A points layer's size on screen: the 3-D scene's grow and shrink with scenePointSize.
  double shownPointSize(const vtkRenderer* renderer, double pointSize) const;
  /// A points layer that shows a subsample while the camera moves; in the scene, over `pointBudget`
  /// points, those its view asks for when still. Its points are `positions`, or with a `source`
  /// (`positions` empty) that cloud's, drawn where they lie.
  void setPointLayer(const std::string& name, vtkRenderer* renderer, std::vector<Eigen::Vector3f> positions,
                     std::vector<Rgb> colors, double pointSize, bool defaultVisible,
                     std::shared_ptr<const PointCloud> source = nullptr);
  /// Before the scene is drawn still: when the shown filed layers have more points together than
  /// the budget, each takes its share of it (in proportion to its points) from the camera's view,
  /// when the view or the share changed since; else every point.
  void choosePointsInView();
  /// `points budget N|all`: the budget the next still frame shares out; returns the message.
  std::string setPointBudget(const std::string& word);
  /// "points drawn: 4998311 of 99744347" when shown layers draw their share of the budget.
  std::string pointBudgetCaption() const;
  void buildPointLayers();
  /// A scene point layer hidden at start: built now if shown, else registered empty and built by
  /// `build` the first time it is shown (buildDeferredLayer). A site's preprocessed and plane
  /// points are tens of millions, mostly never looked at.
  void setDeferredPointLayer(const std::string& name, std::function<void()> build);
  /// Builds a layer registered by setDeferredPointLayer, if it is not built yet.
  void buildDeferredLayer(const std::string& name);
  /// Draws the scene's point layers only inside `pointClip` (clipping planes).
  void applyPointClip();
  /// The faces of `pointClip` in display co-ordinates as (normal, offset): n.x + offset >= 0 is kept.
  std::vector<std::pair<Eigen::Vector3d, double>> pointClipPlanes() const;
  /// Once a document has points and a network: hides the points above a ceiling that would hide
  /// the network from the first view (ceilingHeight).
  void chooseFirstClip();
  /// `points strays hide|show|toggle`: draws the input points without or with their strays (strayPoints,
  /// computed the first time); returns the message.
  std::string showStrays(const std::string& word);
  /// "points above 9.79 m hidden" and the like, for the clip command's message.
  std::string pointClipText() const;
  /// "z < 9.79 m", "box 2.00 x 3.10 x 1.50 m": the clip in the scene's title.
  std::string pointClipCaption() const;
  /// The up direction of the document (its parameters'; a scan or network takes the studio's
  /// --up on opening). Cameras stand on it; heights, clips and the ceiling are along it.
  UpAxis upAxis() const;
  /// After the parameter up changed (set, rerun): the cameras stand on the new axis, a height clip
  /// along the old one is dropped, the ceiling is looked for along the new one (unless a box
  /// clips) and the points are coloured anew. Whether it had changed.
  bool followUpAxis();
  std::vector<Rgb> inputPointColors();
  void buildNetworkLayers();
  void buildSelectionLayer();
  void buildSphereLayers();
  /// The scene marks the sphere's tile (layer preprocess/tile) while the sphere is shown beside it.
  void showSphereTileBox();
  void buildPlaneLayers();
  void updateColorBar();

  // Views, overlays, cameras.
  void layout();
  void resetSceneCamera();
  void resetSphereCamera();
  void resetPlaneCamera();
  void flyTo(const Eigen::Vector3d& world, double size);
  void updateOverlays();
  /// The notice (warnings from opening, an autosave to recover), wrapped to the view's width.
  void showNotice();
  /// The selection's description, its lines broken to the view's width (infoColumns).
  void showInfo();
  /// The 3-D scene's title: colours, clip, points drawn.
  std::string sceneCaption() const;
  void placeKeysHelp();
  std::string selectionInfo() const;
  std::vector<StageState> stageStates() const;
  void selectStage(Stage stage);

  // Running stages: `run` and `rerun` go through the interpreter, in halves when in the background.
  std::string startRun(const CommandInterpreter::PendingRun& run);
  CommandOutcome finishRun(const CommandInterpreter::PendingRun& run);
  bool poll();

  // Review and edits.
  /// A new interpreter for the document's project (after every open).
  void bindInterpreter();
  /// Runs an edit-vocabulary line (joint, pipe, undo, redo, save) through the interpreter.
  std::string edit(const std::string& line);
  /// Runs an edit that fits a new pipe, then selects that pipe.
  std::string editSelectingNewPipe(const std::string& line);
  /// After an edit, undo, redo or new network: drops a vanished selection and redraws the network.
  void networkChanged();
  /// The selected joint or pipe as an element of the review queue (decided or not); none when
  /// nothing is selected.
  std::optional<ReviewItem> selectedReviewItem() const;
  /// The proposed joint or pipe after (or before) the selection in the review queue; none when
  /// none is left.
  std::optional<ReviewItem> reviewNeighbour(bool forward) const;
  /// Selects an element of the review queue and flies the camera to it.
  std::string reviewItem(const std::optional<ReviewItem>& item);
  /// Where `save` without a path writes: the project's file, or the opened file as .piperun.
  std::filesystem::path defaultProjectPath() const;

  // Interaction.
  void onKey();
  /// The command line's keys while it is open (Return runs, Escape closes, BackSpace erases);
  /// false when it is closed.
  bool commandLineKey(const std::string& key);
  void typeCharacter(unsigned codepoint);
  void onLeftPress();
  void onLeftRelease();
  /// Picks at window pixel (x, y) like a click; `addPipe` (Shift+click) makes a picked pipe the second selected one.
  void pick(int x, int y, bool doubleClick, bool addPipe = false);
  /// The world point (metres) of the front-most surface of the named scene layers under window pixel (x, y), and
  /// the element there (-1 for points); nullopt when nothing visible is there.
  std::optional<std::pair<Eigen::Vector3d, int>> pickSurface(int x, int y, std::initializer_list<const char*> names);
  /// The two selected pipes (first, second); throws naming `action` when fewer are selected.
  std::pair<int, int> selectedPipePair(const char* action) const;
  /// Shows the fit box around world bounds (xmin, xmax, ymin, ymax, zmin, zmax; metres).
  void showFitBox(const std::array<double, 6>& bounds);
  /// The fit box shown, in world co-ordinates; throws when it is hidden.
  BoundingBox fitBoxBounds() const;
  /// When the end handle is on: puts it on the selected pipe's end nearer the camera (the same end while the
  /// same pipe stays selected); hides it when no pipe is selected.
  void placeEndHandle();
  /// Moves the handle's pipe end to where the handle is: one undoable edit.
  std::string applyEndHandle();
  void registerCommands();
  std::vector<std::string> keyHelpLines() const;

  Studio& owner;
  vtkRenderWindow* window;
  vtkRenderWindowInteractor* interactor;
  StudioOptions options;
  vtkNew<vtkRenderer> scene, sphere, plane, overlay;
  vtkNew<vtkRenderer> highlightLayer;  ///< Over the scene, sharing its camera.
  /// Under the stage bar: clears its strip each frame (the overlay above does not erase, so a
  /// moved or retitled slider would leave its old drawing behind).
  vtkNew<vtkRenderer> barBase;
  vtkNew<StudioInteractorStyle> style;
  vtkNew<vtkBoxWidget2> fitBox;       ///< Axis-aligned box around the points `box fit` fits a pipe to.
  vtkNew<vtkHandleWidget> endHandle;  ///< Drags a pipe end; releasing it moves the end.
  bool handleOn = false;              ///< `handle on`: the handle follows the selected pipe.
  int handlePipe = -1;                ///< The pipe whose end the handle drags; -1 when hidden.
  bool handleAtStart = false;         ///< Which end: the pipe's start or its end.
  CommandRegistry commands;
  std::vector<std::pair<std::string, std::string>> keyBindings;  ///< key, command

  Document document;
  Eigen::Vector3d displayOrigin = Eigen::Vector3d::Zero();
  /// The input's bounds (of its finite points) and intensity range, measured once on opening: the
  /// colour bar reads them at every overlay update, and a pass over a site's points takes a while.
  BoundingBox inputBounds;
  std::pair<float, float> inputIntensities{0.0f, 0.0f};
  std::shared_ptr<const PreprocessResult> preprocessed;
  std::shared_ptr<const std::vector<TileReconstruction>> tiles;
  PipelineParams tileParams;  ///< What `tiles` were made with...
  bool tilesMatchPreprocessed = false;  ///< ...and whether from `preprocessed` (or from the one it replaced).
  /// The rounds of one tile with the sphere samples and circle candidates the pipeline let go of,
  /// made again for the views when they show that tile.
  mutable int viewSamplesTile = -1;
  mutable std::vector<TileRound> viewSamplesRounds;
  std::vector<DirectionRef> directions;
  std::optional<SurfaceDistances> inputDistances;
  std::vector<int> inputToKept;
  std::vector<int> segmentCache;

  std::map<std::string, Layer> layers;
  std::map<std::string, bool> visibility;  ///< Kept by name across re-registration.
  std::map<std::string, PointLayerLod> pointLods;
  std::map<std::string, std::function<void()>> deferredLayers;  ///< Hidden point layers not built yet.
  /// The point layers are drawn as their subsamples: while the camera moves, and while stages run
  /// in the background (a frame of every point, redrawn for each progress step, would take the
  /// cores from the run under software rendering).
  bool coarsePoints = false;
  /// The size of the 3-D scene's input points in pixels (`points size`; the preprocessed points are
  /// drawn a pixel larger, to tell them apart): 2, or 1 for a scan of over kDenseScanPoints.
  int scenePointSize = 2;
  /// The most points a scene layer draws when the camera is still (`points budget`).
  std::size_t pointBudget = 0;
  bool straysHidden = false;  ///< `points strays hide`: the input points' strays are not drawn.
  std::vector<bool> strays;   ///< strayPoints of the input, once asked for.

  ViewMode viewMode = ViewMode::All;
  PointColor pointColor = PointColor::Height;
  PipeColor pipeColor = PipeColor::Run;
  /// The region (world, m; sides at infinity are open) the scene's points are drawn in: a range of
  /// heights, or the fit box; none: all points are drawn.
  std::optional<BoundingBox> pointClip;
  std::optional<BoundingBox> lastPointClip;  ///< What `clip toggle` brings back.
  bool firstClipChosen = false;                        ///< chooseFirstClip has decided, or the user clipped.
  UpAxis shownUp = UpAxis::PlusZ;  ///< The up direction the cameras stand on and the colours and clip follow.
  Selection selection;
  int selectedDirection = -1;
  Stage selectedStage = Stage::Placement;
  bool helpShown = false;
  bool reviewShown = false;  ///< The review counters overlay.
  bool noticeShown = false;  ///< What opening reported (warnings, a newer autosave).
  bool widgetsShown = true;
  bool quit = false;
  std::string message;
  std::optional<std::string> commandLine;  ///< The typed command while the command line is open.

  std::unique_ptr<CommandInterpreter> interpreter;  ///< Edits document.project(); rebound on open.

  vtkSmartPointer<vtkTextActor> statusText, infoText, helpCommandsText, helpKeysText, progressText;
  vtkSmartPointer<vtkTextActor> reviewText, noticeText;
  vtkSmartPointer<vtkTextActor> sceneTitle, sphereTitle, planeTitle;
  vtkNew<vtkScalarBarActor> colorBar;
  std::vector<vtkSmartPointer<vtkTextActor>> jointLegend;  ///< One line per joint status.
  std::unique_ptr<StageBar> stageBar;
  int laidOutWidth = 0, laidOutHeight = 0;
  std::size_t noticeColumns = 120;  ///< Characters a notice line holds across the view (layout()).
  std::size_t infoColumns = 120;    ///< Characters an info line holds left of the colour bar (layout()).

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
  CommandInterpreter::PendingRun pendingRun;

  // Click detection.
  int pressX = 0, pressY = 0;
  std::chrono::steady_clock::time_point lastClickTime;
  int lastClickX = -100, lastClickY = -100;
};

}  // namespace piperun::ui
