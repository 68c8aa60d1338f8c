// The studio's named commands and the keys bound to them.

#include "studio_impl.h"

#include "piperun/error.h"
#include "piperun/io/network_export.h"
#include "piperun/io/output_path.h"
#include "piperun/spacing.h"

#include <vtkActor.h>
#include <vtkCamera.h>
#include <vtkHandleRepresentation.h>
#include <vtkWidgetRepresentation.h>
#include <vtkNew.h>
#include <vtkPNGWriter.h>
#include <vtkPolyData.h>
#include <vtkProperty.h>
#include <vtkRenderWindow.h>
#include <vtkWindowToImageFilter.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <limits>

namespace piperun::ui {

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

  commands.add(
      "select", "pipe ID [ID2] | joint ID | direction|tile N|next|previous | none",
      "select an element (highlighted, described bottom left), two pipes (to merge or join), a principal direction "
      "(the plane view follows), or a tile's first direction (the sphere shows that tile)",
      [this](const std::vector<std::string>& args) {
        const char* usage = "select pipe ID [ID2] | joint ID | direction|tile N|next|previous | none";
        expectArguments(args, 1, 3, usage);
        const bool directionSelected = args[0] == "direction" || args[0] == "tile";
        bool directionChanged = false;
        if (args[0] == "none") {
          selection = {};
        } else {
          expectArguments(args, 2, args[0] == "pipe" ? 3 : 2, usage);
          const int directionCount = static_cast<int>(directions.size());
          const bool step = directionSelected && (args[1] == "next" || args[1] == "previous");
          if (step && directionCount == 0) throw CommandError("no directions yet: run the directions stage");
          const int id = args[0] == "tile"   ? directionOfTile(args[1])
                         : !step             ? parseInt(args[1], "the id")
                         : args[1] == "next" ? (selectedDirection + 1) % directionCount
                                             : (selectedDirection + directionCount - 1) % directionCount;
          if (args[0] == "pipe") {
            if (!document.network().findPipe(id)) throw CommandError("no pipe " + args[1]);
            selection = {Selection::Kind::Pipe, id};
            if (args.size() == 3) {
              const int second = parseInt(args[2], "the second pipe's id");
              if (!document.network().findPipe(second)) throw CommandError("no pipe " + args[2]);
              if (second == id) throw CommandError("select two different pipes");
              selection.secondPipe = second;
            }
            // The plane view follows to a direction where the pipe's circle was found.
            const int direction = directionShowingPipe(id);
            if (direction >= 0 && direction != selectedDirection) {
              selectedDirection = direction;
              buildSphereLayers();
              directionChanged = true;
            }
          } else if (args[0] == "joint") {
            if (!document.network().findJoint(id)) throw CommandError("no joint " + args[1]);
            selection = {Selection::Kind::Joint, id};
          } else if (directionSelected) {
            if (id < 0 || id >= static_cast<int>(directions.size()))
              throw CommandError("no direction " + args[1] + " (there are " + std::to_string(directions.size()) + ")");
            selectedDirection = id;
            buildSphereLayers();
          } else {
            throw CommandError(std::string("usage: ") + usage);
          }
        }
        buildSelectionLayer();
        buildPlaneLayers();
        if (directionSelected || directionChanged) resetPlaneCamera();
        updateOverlays();
        if (args[0] == "none") return std::string("selection cleared");
        if (!directionSelected) return "selected " + args[0] + " " + args[1] + (args.size() == 3 ? " and " + args[2] : "");
        std::string selected = "selected direction " + std::to_string(selectedDirection);
        if (const int tile = sphereTile(); tile >= 0)
          selected += " (tile " + std::to_string(tileIdOf(tile)) + ")";
        return selected;
      });

  commands.add("fly", "", "move the 3-D camera to the selected pipe or joint (nothing selected: to the sphere's tile)",
               [this](const std::vector<std::string>& args) {
                 expectArguments(args, 0, 0, "fly");
                 const PipeNetwork& network = document.network();
                 if (selection.kind == Selection::Kind::Pipe) {
                   const Pipe& pipe = *network.findPipe(selection.id);
                   flyTo(0.5 * (pipe.start + pipe.end), std::max(pipe.length() / 2.0, 4.0 * pipe.radius));
                 } else if (selection.kind == Selection::Kind::Joint) {
                   const Joint& joint = *network.findJoint(selection.id);
                   flyTo(joint.position(), std::max(joint.length(), 12.0 * joint.radius));
                 } else if (const auto cube = sphereTileCube()) {
                   flyTo(cube->center(), 0.5 * cube->size().norm());
                   return "camera on tile " + std::to_string(tileIdOf(sphereTile()));
                 } else {
                   throw CommandError("nothing selected to fly to");
                 }
                 return std::string("camera on the selection");
               });

  commands.add("color", "points MODE | pipes MODE",
               "colour the input points (height|intensity|rgb|segment|element|qa) or the pipes "
               "(run|radius|confidence|plain)",
               [this](const std::vector<std::string>& args) {
                 expectArguments(args, 2, 2, "color points MODE | color pipes MODE");
                 if (args[0] == "points") {
                   const PointColor mode = parseName(kPointColors, args[1], "point colour");
                   const PointCloud* cloud = document.input().get();
                   if (!cloud) throw CommandError("no points: this document is a network");
                   if (mode == PointColor::Intensity && !cloud->hasIntensity())
                     throw CommandError("the scan has no intensity");
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
                 if (args[1] == "on")
                   shown = true;
                 else if (args[1] == "off")
                   shown = false;
                 else if (args[1] == "toggle")
                   shown = !shown;
                 else
                   throw CommandError("usage: layer NAME on|off|toggle");
                 if (shown) buildDeferredLayer(args[0]);
                 layers[args[0]].prop->SetVisibility(shown);
                 updateOverlays();
                 return args[0] + (shown ? " on" : " off");
               });

  commands.add("layers", "", "list the layers and whether they are shown",
               [this](const std::vector<std::string>& args) {
                 expectArguments(args, 0, 0, "layers");
                 // Lines of at most 80 characters: the status line must not run into the other views.
                 std::string list, line;
                 for (const auto& [name, layer] : layers) {
                   const std::string entry = name + (visibility[name] ? "" : " (off)");
                   if (!line.empty() && line.size() + 2 + entry.size() > 80) {
                     list += line + "\n";
                     line.clear();
                   }
                   line += (line.empty() ? "" : "  ") + entry;
                 }
                 return list + line;
               });

  commands.add("points", "size PX|larger|smaller | strays hide|show|toggle | budget N|all",
               "the size of the 3-D scene's points in pixels, 1 to 10 (2 at start; the preprocessed points one more); "
               "hide or show the scan's stray points (scattered through the air); the most points the scene's layers "
               "draw together when the camera is still (5000000 at start; over it they draw those in view, the near "
               "ones densest)",
               [this](const std::vector<std::string>& args) {
                 const char* usage = "points size PX|larger|smaller | strays hide|show|toggle | budget N|all";
                 expectArguments(args, 2, 2, usage);
                 if (args[0] == "strays") return showStrays(args[1]);
                 if (args[0] == "budget") return setPointBudget(args[1]);
                 if (args[0] != "size") throw CommandError(std::string("usage: ") + usage);
                 const int size = args[1] == "larger"    ? scenePointSize + 1
                                  : args[1] == "smaller" ? scenePointSize - 1
                                                         : parseInt(args[1], "the size in pixels");
                 if (size < 1 || size > 10) throw CommandError("points are drawn 1 to 10 pixels wide");
                 scenePointSize = size;
                 for (const auto& [name, lod] : pointLods) {
                   const Layer& layer = layers.at(name);
                   vtkActor::SafeDownCast(layer.prop)->GetProperty()->SetPointSize(
                       static_cast<float>(shownPointSize(layer.renderer, lod.pointSize) * options.uiScale));
                 }
                 return "scene points drawn at " + std::to_string(size) + " px";
               });

  commands.add(
      "clip", "Z_MAX | Z_MIN Z_MAX | box | off | toggle",
      "draw the scene's points only below height Z_MAX, between two heights (along the up axis, m: the height colour bar's) or "
      "inside the fit box; off shows them all, toggle switches between the last clip and none",
      [this](const std::vector<std::string>& args) {
        expectArguments(args, 1, 2, "clip Z_MAX | Z_MIN Z_MAX | box | off | toggle");
        if (!document.input()) throw CommandError("no points: this document is a network");
        constexpr double kOpen = std::numeric_limits<double>::infinity();
        if (args.size() == 1 && (args[0] == "off" || args[0] == "toggle")) {
          if (pointClip) {
            lastPointClip = pointClip;
            pointClip.reset();
          } else if (args[0] == "toggle") {
            if (!lastPointClip) {
              const auto height = ceilingHeight(*document.input(), document.network(), upAxis());
              if (!height) throw CommandError("no ceiling over the network to clip: give a height (clip Z_MAX)");
              lastPointClip = heightRange(-kOpen, *height, upAxis());
            }
            pointClip = lastPointClip;
          }
        } else if (args.size() == 1 && args[0] == "box") {
          pointClip = fitBoxBounds();
        } else {
          const double low = args.size() == 2 ? parseDouble(args[0], "Z_MIN") : -kOpen;
          const double high = parseDouble(args.back(), "Z_MAX");
          if (!std::isfinite(high) || std::isnan(low)) throw CommandError("heights must be finite numbers (metres)");
          if (!(low < high)) throw CommandError("Z_MIN must be below Z_MAX");
          pointClip = heightRange(low, high, upAxis());
        }
        firstClipChosen = true;
        applyPointClip();
        updateOverlays();
        return pointClipText();
      });

  // `run` and `rerun` are the interpreter's, run in the background when the studio has a window.
  for (const char* word : {"run", "rerun"}) {
    const bool rerun = std::string(word) == "rerun";
    commands.add(word, rerun ? "STAGE [key=value ...]" : "[STAGE]",
                 rerun ? "set the stage's parameters (key or section.key) and re-run it; the later stages become stale"
                       : "run the stale stages up to STAGE (default: all); a new network takes the review over",
                 [this, word](const std::vector<std::string>& args) {
                   if (worker.joinable()) throw CommandError("a run is in progress (Esc cancels it)");
                   std::string line = word;
                   for (const auto& arg : args) line += " " + arg;
                   std::optional<CommandInterpreter::PendingRun> run;
                   try {
                     run = interpreter->prepareRun(line);
                   } catch (const piperun::CommandError& error) {
                     throw CommandError(error.what());
                   }
                   return startRun(*run);
                 });
  }

  commands.add("set", "section.key=value ...", "set parameters (the affected stages become stale)",
               [this](const std::vector<std::string>& args) {
                 if (args.empty()) throw CommandError("usage: set section.key=value ...");
                 Pipeline* pipeline = document.pipeline();
                 if (!pipeline) throw CommandError("parameters belong to scans; this document is a network");
                 if (worker.joinable()) throw CommandError("a run is in progress (Esc cancels it)");
                 PipelineParams params = pipeline->params();
                 try {
                   for (const auto& assignment : args) setParam(params, assignment);
                   pipeline->setParams(params);
                 } catch (const std::exception& error) {
                   throw CommandError(error.what());
                 }
                 recordPipelineState(document.project(), *pipeline);
                 const bool turned = followUpAxis();
                 if (turned) applyPointClip();
                 selectStage(selectedStage);
                 updateOverlays();
                 return std::string(turned ? "parameters set; the cameras stand on " + toString(upAxis()) : "parameters set");
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

  commands.add("cancel", "", "stop the running stages at their next safe point",
               [this](const std::vector<std::string>& args) {
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
                 if (args[0] == "azimuth")
                   camera->Azimuth(value);
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

  // The edit vocabulary (docs/STUDIO.md, "Edit commands"): each edit is one undoable step.
  const std::vector<std::array<const char*, 3>> editWords{
      {"joint", "ID accept|reject|propose | add A B",
       "review a joint (rejected: faded, out of the runs), or join two pipes as the joints stage would"},
      {"pipe", "ID EDIT | fit-box X0 Y0 Z0 X1 Y1 Z1 | fit-point X Y Z [REACH]",
       "EDIT: delete, restore, radius R, snap, merge B, split X Y Z, move-end start|end X Y Z; or fit a new pipe "
       "to the points in a box or around a picked point"},
      {"undo", "", "undo the last edit"},
      {"redo", "", "redo the last undone edit"}};
  for (const auto& [word, arguments, description] : editWords) {
    commands.add(word, arguments, description, [this, word = std::string(word)](const std::vector<std::string>& args) {
      std::string line = word;
      for (const auto& arg : args) line += " " + arg;
      return edit(line);
    });
  }

  commands.add("save", "[PATH]", "save the project (default: its file, or the opened file as .piperun)",
               [this](const std::vector<std::string>& args) {
                 expectArguments(args, 0, 1, "save [PATH]");
                 const std::string message = edit("save " + (args.empty() ? defaultProjectPath().string() : args[0]));
                 noticeShown = false;
                 updateOverlays();
                 return message;
               });

  commands.add("export", "FILE [accepted]",
               "export the reviewed network (" + exportFileKinds() + ": docs/FORMATS.md); accepted: what is proposed left out",
               [this](const std::vector<std::string>& args) {
                 expectArguments(args, 1, 2, "export FILE [accepted]");
                 if (args.size() == 2 && args[1] != "accepted") throw CommandError("expected \"export FILE [accepted]\"");
                 return edit("export " + args[0] + (args.size() == 2 ? " accepted" : ""));
               });

  commands.add("recover", "", "open the project's newer autosave in its place (save then writes it over the project)",
               [this](const std::vector<std::string>& args) {
                 expectArguments(args, 0, 0, "recover");
                 if (!document.newerAutosave()) throw CommandError("no autosave newer than the project");
                 const std::filesystem::path autosave = *document.newerAutosave();
                 const ViewMode shownViews = viewMode;  // The same project: keep the views as they were.
                 try {
                   OpenedProject opened = openProject(autosave);
                   opened.project.file = document.project().file;  // Saving goes to the project, not the sidecar.
                   open(Document::fromProject(std::move(opened), document.path()));
                 } catch (const InputError& error) {
                   throw CommandError(error.what());
                 }
                 viewMode = shownViews;
                 layout();
                 noticeShown = false;
                 updateOverlays();
                 return "recovered " + autosave.string() + " (save writes it over the project)";
               });

  commands.add("review", "next|previous|accept|reject|delete|restore|on|off",
               "step through the proposed joints and pipes, lowest confidence first (selects, flies); accept or "
               "reject the selected joint or pipe (a rejected pipe is deleted), then go to the next; delete or "
               "restore the selected pipe; show or hide the review counters",
               [this](const std::vector<std::string>& args) {
                 expectArguments(args, 1, 1, "review next|previous|accept|reject|delete|restore|on|off");
                 const std::string& action = args[0];
                 if (action == "on" || action == "off") {
                   reviewShown = action == "on";
                   updateOverlays();
                   return "review counters " + action;
                 }
                 if (action == "next" || action == "previous") return reviewItem(reviewNeighbour(action == "next"));
                 if (action == "accept" || action == "reject") {
                   if (selection.kind == Selection::Kind::None) throw CommandError("select a joint or pipe to " + action);
                   const bool joint = selection.kind == Selection::Kind::Joint;
                   const std::string verb = joint || action == "accept" ? action : "delete";
                   const std::string decided =
                       edit((joint ? "joint " : "pipe ") + std::to_string(selection.id) + " " + verb);
                   const std::optional<ReviewItem> next = reviewNeighbour(true);
                   reviewShown = true;
                   if (!next) {
                     updateOverlays();
                     return decided + "; nothing proposed left";
                   }
                   return decided + "; next: " + reviewItem(next);
                 }
                 if (action == "delete" || action == "restore") {
                   if (selection.kind != Selection::Kind::Pipe) throw CommandError("select a pipe to " + action);
                   reviewShown = true;
                   return edit("pipe " + std::to_string(selection.id) + " " + action);
                 }
                 throw CommandError("usage: review next|previous|accept|reject|delete|restore|on|off");
               });

  commands.add("radius", "R|snap", "set the selected pipe's radius to R metres, or snap it to the nearest nominal size",
               [this](const std::vector<std::string>& args) {
                 expectArguments(args, 1, 1, "radius R|snap");
                 if (selection.kind != Selection::Kind::Pipe) throw CommandError("select a pipe to change its radius");
                 const std::string pipe = "pipe " + std::to_string(selection.id);
                 if (args[0] == "snap") return edit(pipe + " snap");
                 return edit(pipe + " radius " + format("%.17g", parseDouble(args[0], "the radius")));
               });

  commands.add("merge", "", "merge the second selected pipe into the first (Shift+click selects the second)",
               [this](const std::vector<std::string>& args) {
                 expectArguments(args, 0, 0, "merge");
                 const auto [first, second] = selectedPipePair("merge");
                 return edit("pipe " + std::to_string(first) + " merge " + std::to_string(second));
               });

  commands.add("join", "", "add a joint between the two selected pipes, typed as the joints stage would",
               [this](const std::vector<std::string>& args) {
                 expectArguments(args, 0, 0, "join");
                 const auto [first, second] = selectedPipePair("join");
                 return edit("joint add " + std::to_string(first) + " " + std::to_string(second));
               });

  commands.add(
      "pick", "split|fit X Y [REACH]",
      "at window pixel (X, Y), origin bottom left (from a key: under the mouse): split the selected pipe where the "
      "pixel shows it, or fit a new pipe around the scan point there (within REACH m, default 0.25) and select it",
      [this](const std::vector<std::string>& args) {
        expectArguments(args, 3, 4, "pick split X Y | pick fit X Y [REACH]");
        const int x = parseInt(args[1], "X"), y = parseInt(args[2], "Y");
        const std::string pixel = "pixel (" + args[1] + ", " + args[2] + ")";
        owner.render();  // Picking needs the current layout and camera.
        if (args[0] == "split") {
          expectArguments(args, 3, 3, "pick split X Y");
          if (selection.kind != Selection::Kind::Pipe) throw CommandError("select a pipe to split");
          const auto hit = pickSurface(x, y, {"network/pipes", "network/deleted-pipes"});
          if (!hit || hit->second != selection.id)
            throw CommandError(pixel + " is not on pipe " + std::to_string(selection.id));
          return edit("pipe " + std::to_string(selection.id) + " split " + formatPoint(hit->first));
        }
        if (args[0] != "fit") throw CommandError("usage: pick split X Y | pick fit X Y [REACH]");
        const auto hit = pickSurface(x, y, {"input/points", "preprocess/points"});
        if (!hit) throw CommandError("no scan point shown at " + pixel + " (G shows the input points)");
        std::string line = "pipe fit-point " + formatPoint(hit->first);
        if (args.size() == 4) line += " " + format("%.17g", parseDouble(args[3], "the reach"));
        return editSelectingNewPipe(line);
      });

  commands.add(
      "box", "show [X0 Y0 Z0 X1 Y1 Z1] | hide | toggle | fit",
      "show the fit box (around the selection, else the view centre; or between two corners, metres), hide it, or "
      "fit a new pipe to the points inside it (pipe fit-box with its bounds) and select it",
      [this](const std::vector<std::string>& args) {
        const char* usage = "box show [X0 Y0 Z0 X1 Y1 Z1] | hide | toggle | fit";
        expectArguments(args, 1, 7, usage);
        const std::string action = args[0] == "toggle" ? (fitBox->GetEnabled() ? "hide" : "show") : args[0];
        if (action == "hide" || action == "fit") {
          expectArguments(args, 1, 1, usage);
          if (action == "hide") {
            fitBox->Off();
            return std::string("box hidden");
          }
          const BoundingBox box = fitBoxBounds();
          const std::string fitted =
              editSelectingNewPipe("pipe fit-box " + formatPoint(box.min) + " " + formatPoint(box.max));
          fitBox->Off();
          return fitted;
        }
        if (action != "show" || (args.size() != 1 && args.size() != 7)) throw CommandError(std::string("usage: ") + usage);
        Eigen::Vector3d low, high;
        if (args.size() == 7) {
          for (int axis = 0; axis < 3; ++axis) {
            const double a = parseDouble(args[1 + axis], "a corner co-ordinate");
            const double b = parseDouble(args[4 + axis], "a corner co-ordinate");
            low[axis] = std::min(a, b);
            high[axis] = std::max(a, b);
          }
        } else {
          // Around the selection with room for its points, else a box at the view centre.
          const PipeNetwork& network = document.network();
          std::vector<Eigen::Vector3d> axis;
          double margin = 0.0;
          if (selection.kind == Selection::Kind::Pipe) {
            const Pipe& pipe = *network.findPipe(selection.id);
            axis = {pipe.start, pipe.end};
            margin = 1.5 * pipe.radius;
          } else if (selection.kind == Selection::Kind::Joint) {
            const Joint& joint = *network.findJoint(selection.id);
            axis = joint.axis;
            margin = 1.5 * joint.radius;
          } else {
            vtkCamera* camera = scene->GetActiveCamera();
            const double* focus = camera->GetFocalPoint();
            axis = {Eigen::Vector3d(focus[0], focus[1], focus[2]) + displayOrigin};
            margin = 0.1 * camera->GetDistance();
          }
          low = high = axis.front();
          for (const Eigen::Vector3d& point : axis) {
            low = low.cwiseMin(point);
            high = high.cwiseMax(point);
          }
          low.array() -= std::max(margin, 0.05);
          high.array() += std::max(margin, 0.05);
        }
        showFitBox({low.x(), high.x(), low.y(), high.y(), low.z(), high.z()});
        return "box from " + format("%.3f", low.x()) + " " + format("%.3f", low.y()) + " " + format("%.3f", low.z()) +
               " to " + format("%.3f", high.x()) + " " + format("%.3f", high.y()) + " " + format("%.3f", high.z());
      });

  commands.add("handle", "on|off|toggle | drop X Y Z",
               "show a handle on the selected pipe's end nearer the camera: releasing it moves that end (one "
               "undoable edit); drop puts the handle at the point (metres) and releases it",
               [this](const std::vector<std::string>& args) {
                 const char* usage = "handle on|off|toggle | drop X Y Z";
                 expectArguments(args, 1, 4, usage);
                 if (args[0] == "drop") {
                   expectArguments(args, 4, 4, usage);
                   if (handlePipe < 0) throw CommandError("no end handle shown: select a pipe and turn the handle on");
                   const Eigen::Vector3d world(parseDouble(args[1], "X"), parseDouble(args[2], "Y"),
                                               parseDouble(args[3], "Z"));
                   Eigen::Vector3d shown = world - displayOrigin;
                   vtkHandleRepresentation::SafeDownCast(endHandle->GetRepresentation())->SetWorldPosition(shown.data());
                   return applyEndHandle();
                 }
                 expectArguments(args, 1, 1, usage);
                 if (args[0] != "on" && args[0] != "off" && args[0] != "toggle")
                   throw CommandError(std::string("usage: ") + usage);
                 handleOn = args[0] == "toggle" ? !handleOn : args[0] == "on";
                 placeEndHandle();
                 if (!handleOn) return std::string("end handle off");
                 if (handlePipe < 0) return std::string("end handle on: select a pipe");
                 return "end handle on the " + std::string(handleAtStart ? "start" : "end") + " of pipe " +
                        std::to_string(handlePipe);
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

  commands.add("screenshot", "FILE.png", "write the window as a PNG image",
               [this](const std::vector<std::string>& args) {
                 expectArguments(args, 1, 1, "screenshot FILE.png");
                 try {
                   requireWritableFile(args[0]);  // VTK's writer would report a missing folder as a full disk
                 } catch (const OutputError& error) {
                   throw CommandError(error.what());
                 }
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

  commands.add("click", "X Y [double|shift]",
               "click at window pixel (X, Y), origin bottom left: picks like the mouse (double: also flies; shift: "
               "adds a second pipe to the selected one)",
               [this](const std::vector<std::string>& args) {
                 expectArguments(args, 2, 3, "click X Y [double|shift]");
                 if (args.size() == 3 && args[2] != "double" && args[2] != "shift")
                   throw CommandError("usage: click X Y [double|shift]");
                 owner.render();  // Picking needs the current layout and camera.
                 message.clear();
                 pick(parseInt(args[0], "X"), parseInt(args[1], "Y"), args.size() == 3 && args[2] == "double",
                      args.size() == 3 && args[2] == "shift");
                 return message.empty() ? std::string("nothing there") : message;
               });

  commands.add(
      "frames", "N", "time N frames turning the 3-D camera once around, drawn as while dragging and as when still",
      [this](const std::vector<std::string>& args) {
        expectArguments(args, 1, 1, "frames N");
        const int count = parseInt(args[0], "the frame count");
        if (count < 1) throw CommandError("frames needs at least 1 frame");
        vtkNew<vtkCamera> saved;
        saved->DeepCopy(scene->GetActiveCamera());
        auto timeFrames = [&](bool moving) {
          setCoarsePoints(moving);
          owner.render();  // Uploads the points; not timed.
          const auto start = std::chrono::steady_clock::now();
          for (int i = 0; i < count; ++i) {
            scene->GetActiveCamera()->Azimuth(360.0 / count);
            window->Render();
          }
          const std::chrono::duration<double, std::milli> elapsed = std::chrono::steady_clock::now() - start;
          vtkIdType points = 0;
          for (auto& [name, lod] : pointLods)
            if (layerVisible(name) && layers[name].renderer->GetDraw())
              points += (moving ? lod.coarse : lod.full)->GetNumberOfPoints();
          return format("%.1f ms/frame", elapsed.count() / count) + " (" + std::to_string(points) + " points drawn)";
        };
        const std::string moving = timeFrames(true);
        const std::string still = timeFrames(false);
        setCoarsePoints(worker.joinable());  // A run still going draws them coarse.
        scene->GetActiveCamera()->DeepCopy(saved);
        scene->ResetCameraClippingRange();
        return "moving " + moving + ", still " + still;
      });

  commands.add("open", "FILE", "open a scan, a network (.json) or a project (.piperun) in place of the current one",
               [this](const std::vector<std::string>& args) {
                 if (args.empty()) throw CommandError("usage: open FILE");
                 std::string path = args[0];
                 for (std::size_t i = 1; i < args.size(); ++i) path += " " + args[i];  // Names with blanks.
                 try {
                   open(Document::open(path, Progress::none(), options.scanUnits, options.up));
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
                 {"next", "select tile next"},
                 {"prior", "select tile previous"},
                 {"f", "fly"},
                 {"n", "review next"},
                 {"p", "review previous"},
                 {"a", "review accept"},
                 {"r", "review reject"},
                 {"delete", "review delete"},
                 {"insert", "review restore"},
                 {"ctrl+z", "undo"},
                 {"ctrl+y", "redo"},
                 {"ctrl+s", "save"},
                 {"ctrl+r", "recover"},
                 {"c", "color points height"},
                 {"q", "color points qa"},
                 {"e", "color points element"},
                 {"s", "color points segment"},
                 {"i", "color points intensity"},
                 {"u", "color pipes run"},
                 {"d", "color pipes radius"},
                 {"k", "color pipes confidence"},
                 {"g", "layer input/points toggle"},
                 {"o", "layer preprocess/points toggle"},
                 {"m", "layer preprocess/normals toggle"},
                 {"t", "layer network/pipes toggle"},
                 {"j", "layer network/joints toggle"},
                 {"z", "clip toggle"},
                 {"y", "points strays toggle"},
                 {"plus", "points size larger"},
                 {"minus", "points size smaller"},
                 {"v", "rerun directions"},
                 {"l", "rerun placement"},
                 {"x", "rerun extents"},
                 {"w", "radius snap"},
                 {"shift+m", "merge"},
                 {"shift+j", "join"},
                 {"shift+s", "pick split X Y"},
                 {"shift+f", "pick fit X Y"},
                 {"b", "box toggle"},
                 {"shift+b", "box fit"},
                 {"shift+e", "handle toggle"}};
}

std::vector<std::string> Studio::Impl::keyHelpLines() const {
  // Consecutive bindings whose commands differ only in their last word share a line of at most 48
  // characters, so that the list fits beside the commands: "U D K   color pipes run|radius|confidence".
  struct Group {
    std::string keys, prefix, lastWords;
    std::string text() const {
      return keys + std::string(keys.size() < 8 ? 8 - keys.size() : 2, ' ') + (prefix.empty() ? "" : prefix + " ") +
             lastWords;
    }
  };
  constexpr std::size_t kMaxLine = 48;
  std::vector<Group> groups;
  for (const auto& [key, line] : keyBindings) {
    // "ctrl+z" is shown as "Ctrl+Z", "shift+m" as "Shift+M", "delete" as "Delete".
    // X11 names Page Down and Page Up "Next" and "Prior"; the help uses the keys' labels.
    static const std::map<std::string, std::string> kKeyLabels{
        {"next", "PageDown"}, {"prior", "PageUp"}, {"plus", "+"}, {"minus", "-"}};
    const auto label = kKeyLabels.find(key);
    std::string shown = label != kKeyLabels.end() ? label->second : key;
    shown[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(shown[0])));
    const std::size_t plus = shown.find('+');
    if (plus != std::string::npos && plus + 2 == shown.size())
      shown[plus + 1] = static_cast<char>(std::toupper(static_cast<unsigned char>(shown[plus + 1])));
    const std::size_t lastSpace = line.rfind(' ');
    const std::string prefix = lastSpace == std::string::npos ? std::string() : line.substr(0, lastSpace);
    const std::string lastWord = lastSpace == std::string::npos ? line : line.substr(lastSpace + 1);
    if (!prefix.empty() && !groups.empty() && groups.back().prefix == prefix) {
      const Group joined{groups.back().keys + " " + shown, prefix, groups.back().lastWords + "|" + lastWord};
      if (joined.text().size() <= kMaxLine) {
        groups.back() = joined;
        continue;
      }
    }
    groups.push_back({shown, prefix, lastWord});
  }
  std::vector<std::string> lines;
  for (const Group& group : groups) lines.push_back(group.text());
  lines.push_back("click   select a pipe, joint, direction, circle");
  lines.push_back("double-click  fly to the clicked pipe or joint");
  lines.push_back("Shift+click  add a second pipe (merge, join)");
  lines.push_back("X Y     the pixel under the mouse");
  lines.push_back(":       type a command (Return runs it)");
  return lines;
}

std::string Studio::Impl::showStrays(const std::string& word) {
  if (word != "hide" && word != "show" && word != "toggle") throw CommandError("usage: points strays hide|show|toggle");
  const PointCloud* cloud = document.input().get();
  if (!cloud) throw CommandError("no points: this document is a network");
  straysHidden = word == "toggle" ? !straysHidden : word == "hide";
  if (straysHidden && strays.empty()) {
    // Blocks of 15 point spacings: a surface fills them, a point in the air is alone in its.
    const double cell = std::max(kStrayCellSpacings * estimatePointSpacing(*cloud), 0.01);
    strays = strayPoints(*cloud, cell, kStrayNeighbours);
  }
  buildPointLayers();
  updateOverlays();
  if (!straysHidden) return std::string("stray points shown");
  const auto count = std::count(strays.begin(), strays.end(), true);
  return std::to_string(count) + format(" stray points hidden (%.2g %% of the scan)", 100.0 * count / std::max<double>(1, strays.size()));
}

std::string Studio::Impl::setPointBudget(const std::string& word) {
  if (word == "all") {
    pointBudget = std::numeric_limits<std::size_t>::max();
  } else {
    const int budget = parseInt(word, "the most points drawn");
    if (budget < 1) throw CommandError("the point budget is at least 1 point");
    pointBudget = static_cast<std::size_t>(budget);
  }
  updateOverlays();  // The next still frame takes the shares of the new budget (choosePointsInView).
  return word == "all" ? std::string("scene layers draw every point when still")
                       : "scene layers draw at most " + std::to_string(pointBudget) + " points when still";
}

}  // namespace piperun::ui
