#pragma once
// PipeRun Studio's scene: the document's named layers in three views of one render window (3-D
// scene, Gaussian sphere, projection plane), the stage bar and parameter slider, selection,
// text overlays and the named commands. The window backend (GLFW window or OSMesa buffer) creates
// the vtkRenderWindow and its interactor and drives the frames; everything else lives here.

#include "piperun/ui/commands.h"
#include "piperun/ui/document.h"

#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>

class vtkRenderWindow;
class vtkRenderWindowInteractor;

namespace piperun::ui {

struct StudioOptions {
  /// Run stages on a background thread (the window goes on drawing the previous layers; poll()
  /// picks up the result). Off for scripts and the headless renderer: commands then finish before
  /// they return.
  bool backgroundStages = false;
  /// Scale of text and widgets (the window's content scale on HiDPI screens).
  double uiScale = 1.0;
  /// Points drawn while the camera moves; the whole cloud is drawn when it stops.
  std::size_t interactivePoints = 120000;
  /// The most points the 3-D scene's point layers draw together when the camera is still: over it,
  /// each draws its share of the points in view, the near ones densest (`points budget` changes it).
  std::size_t pointBudget = 5'000'000;
  /// The unit of the coordinates of the scans this studio opens (lengthUnitNames(); empty: the unit
  /// a file declares, else metres); a project's scan is read in the unit the project records.
  std::string scanUnits;
  /// The up direction of the scans and networks this studio opens (none: z, or the one a network
  /// records; a project keeps its own).
  std::optional<UpAxis> up;
  /// Autosave the project after this many edits (undo and redo count); 0: never.
  int autosaveEdits = 5;
  /// On opening a project with its scan, recompute the stages that were fresh when it was saved
  /// (so the sphere and plane views show them); the reviewed network stays as saved.
  bool restoreStages = true;
  /// Called on the window's thread (from poll()) when a background run has ended, with how it ended.
  std::function<void(const std::string& message)> runFinished;
};

class Studio {
 public:
  /// Adds the views, overlays and widgets to `window`, and binds picking and keys to `interactor`
  /// (which must be attached to `window`).
  Studio(vtkRenderWindow* window, vtkRenderWindowInteractor* interactor, const StudioOptions& options = {});
  ~Studio();
  Studio(const Studio&) = delete;
  Studio& operator=(const Studio&) = delete;

  /// Shows `document` (replacing what was open) and resets the cameras.
  void open(Document document);
  /// Opens a scan, a network or a project file; throws InputError.
  void open(const std::filesystem::path& path);

  const Document& document() const;

  /// Runs a named command (see commands().helpLines()); returns its message, throws CommandError.
  std::string command(const std::string& line);
  /// Runs a script, one command a line; its runs finish before the next line (even with
  /// backgroundStages). Throws CommandError naming the script and line.
  void runScript(const std::filesystem::path& path);
  const CommandRegistry& commands() const;

  /// Key bindings as "key - command" lines, for the help overlay and docs/STUDIO.md.
  std::vector<std::string> keyHelpLines() const;

  /// Text typed into the window (a Unicode code point, as GLFW's character callback gives it): ':'
  /// opens the command line, whose characters then collect here until Return runs the command.
  void typeText(unsigned codepoint);
  /// Picks up a finished background run and progress; true when the window should be redrawn.
  bool poll();
  /// Lays out the views for the window's current size and renders.
  void render();
  bool busy() const;
  /// Asks a background run to stop at its next safe point.
  void cancel();

  /// "PipeRun Studio - <file name>": the project's file once saved, else the file opened.
  std::string title() const;
  /// Set by the `quit` command; the window backend closes when it sees it.
  bool quitRequested() const;
  /// The status line: the last command's message, or how the last background run ended.
  const std::string& message() const;
  /// Every text the last frame showed over the views (titles, status, selection info, review
  /// counters, help, the colour bar's title), each under its name in brackets: what the render
  /// tests compare exactly, where an image comparison would pass a changed word.
  std::string overlayText() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace piperun::ui
