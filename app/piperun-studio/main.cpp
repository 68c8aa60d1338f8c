// piperun-studio: PipeRun Studio in a GLFW window. Creates the window and its OpenGL context, hands
// them to ui::Studio through a vtkGenericOpenGLRenderWindow, and forwards GLFW's input events to
// VTK's interactor. Everything the user sees and does lives in ui/.

#include "piperun/edit/project.h"
#include "piperun/ui/studio.h"
#include "parse_arguments.h"
#include "studio_options.h"

#include <CLI/CLI.hpp>
#include <GLFW/glfw3.h>

#include <vtkCallbackCommand.h>
#include <vtkCommand.h>
#include <vtkGenericOpenGLRenderWindow.h>
#include <vtkGenericRenderWindowInteractor.h>
#include <vtkNew.h>

#include <algorithm>
#include <cstdio>
#include <exception>
#include <map>
#include <regex>
#include <string>

namespace {

/// What the GLFW callbacks reach through the window's user pointer.
struct StudioWindow {
  GLFWwindow* window = nullptr;
  vtkGenericOpenGLRenderWindow* renderWindow = nullptr;
  vtkGenericRenderWindowInteractor* interactor = nullptr;
  piperun::ui::Studio* studio = nullptr;
  bool redraw = true;

  /// Cursor position in framebuffer pixels with y up, as VTK expects (window coordinates differ on HiDPI).
  void eventPosition(double x, double y, int& pixelX, int& pixelY) const {
    int windowWidth, windowHeight, framebufferWidth, framebufferHeight;
    glfwGetWindowSize(window, &windowWidth, &windowHeight);
    glfwGetFramebufferSize(window, &framebufferWidth, &framebufferHeight);
    const double scaleX = windowWidth > 0 ? static_cast<double>(framebufferWidth) / windowWidth : 1.0;
    const double scaleY = windowHeight > 0 ? static_cast<double>(framebufferHeight) / windowHeight : 1.0;
    pixelX = static_cast<int>(x * scaleX);
    pixelY = framebufferHeight - 1 - static_cast<int>(y * scaleY);
  }

  void setEventInformation(int mods) {
    double x, y;
    glfwGetCursorPos(window, &x, &y);
    int pixelX, pixelY;
    eventPosition(x, y, pixelX, pixelY);
    interactor->SetEventInformation(pixelX, pixelY, (mods & GLFW_MOD_CONTROL) != 0, (mods & GLFW_MOD_SHIFT) != 0);
    interactor->SetAltKey((mods & GLFW_MOD_ALT) != 0);
  }

  void updateTitle() { glfwSetWindowTitle(window, studio->title().c_str()); }

  /// Opens a file and starts the pipeline on it when it is a scan (a project recomputes its fresh stages itself).
  void open(const std::string& path) {
    try {
      studio->command("open " + path);
      if (studio->document().hasPipeline() && !piperun::isProjectFile(path)) studio->command("run");
    } catch (const std::exception& error) {
      std::fprintf(stderr, "piperun-studio: error: %s\n", error.what());
    }
    updateTitle();
    redraw = true;
  }
};

StudioWindow& self(GLFWwindow* window) { return *static_cast<StudioWindow*>(glfwGetWindowUserPointer(window)); }

/// X11 keysym names for the keys the studio binds (VTK's interactors use them).
std::string keySym(int key) {
  static const std::map<int, std::string> kNames{
      {GLFW_KEY_ESCAPE, "Escape"}, {GLFW_KEY_ENTER, "Return"}, {GLFW_KEY_KP_ENTER, "Return"},
      {GLFW_KEY_HOME, "Home"},     {GLFW_KEY_LEFT, "Left"},    {GLFW_KEY_RIGHT, "Right"},
      {GLFW_KEY_UP, "Up"},         {GLFW_KEY_DOWN, "Down"},    {GLFW_KEY_SPACE, "space"},
      {GLFW_KEY_DELETE, "Delete"}, {GLFW_KEY_TAB, "Tab"},      {GLFW_KEY_INSERT, "Insert"},
      {GLFW_KEY_BACKSPACE, "BackSpace"}, {GLFW_KEY_PAGE_DOWN, "Next"}, {GLFW_KEY_PAGE_UP, "Prior"},
      {GLFW_KEY_EQUAL, "plus"},    {GLFW_KEY_KP_ADD, "plus"},  {GLFW_KEY_MINUS, "minus"},
      {GLFW_KEY_KP_SUBTRACT, "minus"}};
  if (key >= GLFW_KEY_A && key <= GLFW_KEY_Z) return std::string(1, static_cast<char>('a' + key - GLFW_KEY_A));
  if (key >= GLFW_KEY_0 && key <= GLFW_KEY_9) return std::string(1, static_cast<char>('0' + key - GLFW_KEY_0));
  const auto found = kNames.find(key);
  return found != kNames.end() ? found->second : std::string();
}

void installCallbacks(GLFWwindow* window) {
  glfwSetCursorPosCallback(window, [](GLFWwindow* w, double, double) {
    auto& app = self(w);
    app.setEventInformation(0);
    app.interactor->InvokeEvent(vtkCommand::MouseMoveEvent);
    app.redraw = true;
  });
  glfwSetMouseButtonCallback(window, [](GLFWwindow* w, int button, int action, int mods) {
    auto& app = self(w);
    app.setEventInformation(mods);
    const bool press = action == GLFW_PRESS;
    unsigned long event = 0;
    if (button == GLFW_MOUSE_BUTTON_LEFT)
      event = press ? vtkCommand::LeftButtonPressEvent : vtkCommand::LeftButtonReleaseEvent;
    if (button == GLFW_MOUSE_BUTTON_MIDDLE)
      event = press ? vtkCommand::MiddleButtonPressEvent : vtkCommand::MiddleButtonReleaseEvent;
    if (button == GLFW_MOUSE_BUTTON_RIGHT)
      event = press ? vtkCommand::RightButtonPressEvent : vtkCommand::RightButtonReleaseEvent;
    if (event) app.interactor->InvokeEvent(event);
    app.redraw = true;
  });
  glfwSetScrollCallback(window, [](GLFWwindow* w, double, double dy) {
    auto& app = self(w);
    app.setEventInformation(0);
    app.interactor->InvokeEvent(dy > 0 ? vtkCommand::MouseWheelForwardEvent : vtkCommand::MouseWheelBackwardEvent);
    app.redraw = true;
  });
  glfwSetKeyCallback(window, [](GLFWwindow* w, int key, int, int action, int mods) {
    if (action == GLFW_RELEASE) return;
    const std::string sym = keySym(key);
    if (sym.empty()) return;
    auto& app = self(w);
    app.setEventInformation(mods);
    const char code = sym.size() == 1 ? sym[0] : 0;
    app.interactor->SetKeyEventInformation((mods & GLFW_MOD_CONTROL) != 0, (mods & GLFW_MOD_SHIFT) != 0, code,
                                           action == GLFW_REPEAT ? 1 : 0, sym.c_str());
    app.interactor->InvokeEvent(vtkCommand::KeyPressEvent);
    app.interactor->InvokeEvent(vtkCommand::CharEvent);
    app.redraw = true;
  });
  glfwSetCharCallback(window, [](GLFWwindow* w, unsigned codepoint) {
    auto& app = self(w);
    app.studio->typeText(codepoint);
    app.redraw = true;
  });
  glfwSetFramebufferSizeCallback(window, [](GLFWwindow* w, int width, int height) {
    auto& app = self(w);
    app.renderWindow->SetSize(width, height);
    app.interactor->UpdateSize(width, height);
    app.redraw = true;
  });
  glfwSetWindowRefreshCallback(window, [](GLFWwindow* w) { self(w).redraw = true; });
  glfwSetDropCallback(window, [](GLFWwindow* w, int count, const char** paths) {
    if (count > 0) self(w).open(paths[0]);
  });
}

/// Shrinks a window size (screen units) to the primary monitor's work area, leaving room for the title bar
/// and frame. With GLFW_SCALE_TO_MONITOR the window is the size times the content scale, so the work
/// area is divided by it.
void fitToWorkArea(int& width, int& height) {
  GLFWmonitor* monitor = glfwGetPrimaryMonitor();
  if (!monitor) return;
  int areaX, areaY, areaWidth, areaHeight;
  glfwGetMonitorWorkarea(monitor, &areaX, &areaY, &areaWidth, &areaHeight);
  float scaleX = 1.0f, scaleY = 1.0f;
  glfwGetMonitorContentScale(monitor, &scaleX, &scaleY);
  constexpr int kFrameWidth = 16, kFrameHeight = 48;
  if (areaWidth > kFrameWidth) width = std::min(width, static_cast<int>((areaWidth - kFrameWidth) / scaleX));
  if (areaHeight > kFrameHeight) height = std::min(height, static_cast<int>((areaHeight - kFrameHeight) / scaleY));
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "PipeRun Studio: inspect a scan's reconstruction stage by stage, or a pipe network.\n"
      "Press H in the window for the keys and commands (docs/STUDIO.md).",
      "piperun-studio"};
  app.set_version_flag("--version", "piperun-studio " PIPERUN_VERSION);
  std::string input, script, size = "1400x860";
  app.add_option("input", input,
                 "Scan (.ply .pcd .xyz .pts .las .e57 ...), network (.json) or project (.piperun); or drop one on "
                 "the window");
  app.add_option("--script", script,
                 "Commands to run once the first pipeline run has finished (one a line, # comments)");
  CLI::Option* sizeOption = app.add_option("--size", size,
                                           "Window size WIDTHxHEIGHT in screen units (default: 1400x860, shrunk to fit "
                                           "the screen's work area)");
  piperun::app::StudioCommandLine shared;
  shared.addTo(app);
  if (const auto exitCode = piperun::app::parseArguments(app, argc, argv, "piperun-studio")) return *exitCode;
  if (!shared.check("piperun-studio")) return 1;
  std::smatch match;
  if (!std::regex_match(size, match, std::regex("([0-9]+)x([0-9]+)")) || std::stoi(match[1]) < 320 ||
      std::stoi(match[2]) < 240) {
    std::fprintf(stderr, "piperun-studio: error: --size: expected WIDTHxHEIGHT of at least 320x240, got '%s'\n",
                 size.c_str());
    return 1;
  }

  glfwSetErrorCallback(
      [](int, const char* description) { std::fprintf(stderr, "piperun-studio: GLFW: %s\n", description); });
  if (!glfwInit()) {
    std::fprintf(stderr, "piperun-studio: error: no display to open a window on (piperun-render draws without one)\n");
    return 2;
  }
  // VTK 9.1 needs OpenGL 3.2 core.
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 2);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_SCALE_TO_MONITOR, GLFW_TRUE);
  glfwWindowHint(GLFW_SAMPLES, 0);
  int windowWidth = std::stoi(match[1]), windowHeight = std::stoi(match[2]);
  if (sizeOption->count() == 0) fitToWorkArea(windowWidth, windowHeight);
  GLFWwindow* window = glfwCreateWindow(windowWidth, windowHeight, "PipeRun Studio", nullptr, nullptr);
  if (!window) {
    std::fprintf(stderr, "piperun-studio: error: cannot create an OpenGL 3.2 core window\n");
    glfwTerminate();
    return 2;
  }
  glfwMakeContextCurrent(window);
  glfwSwapInterval(1);

  int status = 0;
  {
    vtkNew<vtkGenericOpenGLRenderWindow> renderWindow;
    int width, height;
    glfwGetFramebufferSize(window, &width, &height);
    renderWindow->SetSize(width, height);
    renderWindow->SetOwnContext(false);
    renderWindow->SetReadyForRendering(true);
    renderWindow->SetIsCurrent(true);
    renderWindow->InitializeFromCurrentContext();
    // VTK asks for the context before drawing and reports finished frames: both go to GLFW.
    vtkNew<vtkCallbackCommand> makeCurrent;
    makeCurrent->SetClientData(window);
    makeCurrent->SetCallback([](vtkObject*, unsigned long, void* client, void*) {
      glfwMakeContextCurrent(static_cast<GLFWwindow*>(client));
    });
    renderWindow->AddObserver(vtkCommand::WindowMakeCurrentEvent, makeCurrent);
    vtkNew<vtkCallbackCommand> isCurrent;
    isCurrent->SetClientData(window);
    isCurrent->SetCallback([](vtkObject*, unsigned long, void* client, void* answer) {
      *static_cast<bool*>(answer) = glfwGetCurrentContext() == static_cast<GLFWwindow*>(client);
    });
    renderWindow->AddObserver(vtkCommand::WindowIsCurrentEvent, isCurrent);
    vtkNew<vtkCallbackCommand> frame;
    frame->SetClientData(window);
    frame->SetCallback(
        [](vtkObject*, unsigned long, void* client, void*) { glfwSwapBuffers(static_cast<GLFWwindow*>(client)); });
    renderWindow->AddObserver(vtkCommand::WindowFrameEvent, frame);

    vtkNew<vtkGenericRenderWindowInteractor> interactor;
    interactor->SetRenderWindow(renderWindow);
    interactor->EnableRenderOff();  // The loop below draws when something changed.
    interactor->Initialize();

    float scaleX = 1.0f, scaleY = 1.0f;
    glfwGetWindowContentScale(window, &scaleX, &scaleY);
    piperun::ui::StudioOptions options;
    shared.applyTo(options);
    options.backgroundStages = true;
    options.uiScale = std::max(1.0f, scaleX);
    options.runFinished = [](const std::string& message) {
      // Scripts and tests wait for this line; a new network's message names its pipes and joints.
      std::printf("piperun-studio: %s\n", message.c_str());
      std::fflush(stdout);
    };
    piperun::ui::Studio studio(renderWindow, interactor, options);

    StudioWindow state{window, renderWindow, interactor, &studio};
    glfwSetWindowUserPointer(window, &state);
    installCallbacks(window);
    if (!input.empty()) state.open(input);
    bool scriptPending = !script.empty();

    while (!glfwWindowShouldClose(window) && !studio.quitRequested()) {
      glfwWaitEventsTimeout(studio.busy() ? 0.05 : 0.5);
      if (studio.poll()) state.redraw = true;
      if (scriptPending && !studio.busy()) {
        scriptPending = false;
        try {
          studio.runScript(script);
        } catch (const std::exception& error) {
          std::fprintf(stderr, "piperun-studio: error: %s\n", error.what());
          status = 2;
          break;
        }
        studio.render();  // Announced once its result is on screen.
        std::printf("piperun-studio: script done\n");
        std::fflush(stdout);
      }
      if (state.redraw) {
        state.redraw = false;
        state.updateTitle();  // Saving names the project.
        studio.render();
      }
    }
  }
  glfwDestroyWindow(window);
  glfwTerminate();
  return status;
}
