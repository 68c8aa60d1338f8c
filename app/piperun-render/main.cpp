// piperun-render: draws PipeRun Studio's window without a display, through OSMesa, and writes a PNG.
// The same ui::Studio as the studio; only the context provider differs (see osmesa_context.cpp).

#include "osmesa_context.h"

#include "piperun/edit/project.h"
#include "piperun/error.h"
#include "piperun/io/output_path.h"
#include "piperun/progress.h"
#include "piperun/ui/studio.h"
#include "parse_arguments.h"
#include "studio_options.h"

#include <CLI/CLI.hpp>

#include <vtkGenericOpenGLRenderWindow.h>
#include <vtkGenericRenderWindowInteractor.h>
#include <vtkNew.h>

#include <cstdio>
#include <exception>
#include <fstream>
#include <regex>

int main(int argc, char** argv) {
  CLI::App app{
      "Render a PipeRun Studio view of a scan or a network to a PNG, without a display.\n"
      "Given a scan it runs the reconstruction pipeline first. Exit codes: 0 ok, 1 usage,\n"
      "2 bad input or output file or failing script line, 3 internal error.",
      "piperun-render"};
  app.set_version_flag("--version", "piperun-render " PIPERUN_VERSION);
  std::string input, script, output, textOutput, view = "all", size = "1280x800";
  bool noRun = false, listCommands = false;
  app.add_option("input", input, "Scan (.ply .pcd .xyz .pts .las .e57 ...), network (.json) or project (.piperun)");
  app.add_flag("--commands", listCommands, "List the studio's commands and key bindings, then exit");
  app.add_option("--script", script, "Commands to run after opening, one a line (# comments)");
  app.add_option("--view", view, "What to draw: the whole window or one view")
      ->check(CLI::IsMember({"all", "scene", "sphere", "plane"}))
      ->capture_default_str();
  app.add_option("--size", size, "Image size WIDTHxHEIGHT in pixels")->capture_default_str();
  app.add_flag("--no-run", noRun,
               "Show the scan without running the pipeline (a project: without recomputing its fresh stages)");
  app.add_option("-o,--output", output, "PNG to write");
  app.add_option("--text", textOutput, "Also write the texts drawn over the views (titles, status, info) to this file");
  piperun::app::StudioCommandLine shared;
  shared.addTo(app);
  if (const auto exitCode = piperun::app::parseArguments(app, argc, argv, "piperun-render")) return *exitCode;
  if (!shared.check("piperun-render")) return 1;
  if (!listCommands && (input.empty() || output.empty())) {
    std::fprintf(stderr, "piperun-render: error: INPUT and -o OUT.png are required (see --help)\n");
    return 1;
  }

  std::smatch match;
  const std::regex sizePattern("([0-9]+)x([0-9]+)");
  if (!std::regex_match(size, match, sizePattern) || std::stoi(match[1]) < 64 || std::stoi(match[2]) < 64 ||
      std::stoi(match[1]) > 8192 || std::stoi(match[2]) > 8192) {
    std::fprintf(stderr, "piperun-render: error: --size: expected WIDTHxHEIGHT between 64 and 8192, got '%s'\n",
                 size.c_str());
    return 1;
  }
  const int width = std::stoi(match[1]), height = std::stoi(match[2]);

  try {
    if (!listCommands) {
      piperun::requireWritableFile(output);  // before what may be a long run
      if (!textOutput.empty()) piperun::requireWritableFile(textOutput);
    }
    piperun::render::OsMesaContext context(width, height);
    vtkNew<vtkGenericOpenGLRenderWindow> window;
    context.attach(window);
    vtkNew<vtkGenericRenderWindowInteractor> interactor;
    interactor->SetRenderWindow(window);
    interactor->Initialize();

    piperun::ui::StudioOptions options;
    shared.applyTo(options);
    options.autosaveEdits = 0;  // A batch run saves when its script says so.
    options.restoreStages = !noRun;
    piperun::ui::Studio studio(window, interactor, options);
    if (listCommands) {
      std::printf("Commands:\n");
      for (const auto& line : studio.commands().helpLines()) std::printf("  %s\n", line.c_str());
      std::printf("Keys (piperun-studio):\n");
      for (const auto& line : studio.keyHelpLines()) std::printf("  %s\n", line.c_str());
      return 0;
    }
    studio.open(input);
    const piperun::ui::Document& document = studio.document();
    for (const auto& warning : document.warnings())
      std::fprintf(stderr, "piperun-render: warning: %s\n", warning.c_str());
    if (document.newerAutosave()) {
      std::fprintf(stderr, "piperun-render: warning: %s is newer than the project (not opened; open it to recover)\n",
                   document.newerAutosave()->string().c_str());
    }
    if (document.hasPipeline() && !noRun && !piperun::isProjectFile(input)) studio.command("run");
    if (view != "all") {
      studio.command("widgets off");
      studio.command("view " + view);
    }
    if (!script.empty()) {
      studio.runScript(script);
      std::printf("%s\n", studio.message().c_str());
    }
    studio.render();  // Lays the texts out as the screenshot draws them, before it reports itself.
    const std::string overlayText = studio.overlayText();
    studio.command("screenshot " + output);
    std::printf("wrote %s (%dx%d)\n", output.c_str(), width, height);
    if (!textOutput.empty()) {
      std::ofstream text(textOutput);
      text << overlayText;
      if (!text) throw piperun::OutputError(textOutput, "cannot write");
    }
  } catch (const piperun::InputError& error) {
    std::fprintf(stderr, "piperun-render: error: %s\n", error.what());
    return 2;
  } catch (const piperun::OutputError& error) {
    std::fprintf(stderr, "piperun-render: error: %s\n", error.what());
    return 2;
  } catch (const piperun::ui::CommandError& error) {
    std::fprintf(stderr, "piperun-render: error: %s\n", error.what());
    return 2;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "piperun-render: internal error: %s\n", error.what());
    return 3;
  }
  return 0;
}
