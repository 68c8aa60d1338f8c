// piperun: the command-line tool. Parses arguments and hands over to the subcommands.

#include "commands.h"
#include "parse_arguments.h"
#include "piperun/error.h"
#include "piperun/io/network_export.h"
#include "units_option.h"
#include "up_option.h"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <exception>

namespace {

using namespace piperun::cli;

constexpr const char* kVersionText = "piperun " PIPERUN_VERSION;
constexpr const char* kPcfBoreHelp =
    "PCF bores: nominal (the DN whose pipe size is nearest the fit) or outside (the fitted outside diameter, mm)";
constexpr const char* kAcceptedOnlyHelp =
    "Export only what is accepted: proposed pipes and joints, and joints on a pipe left out, are left out too "
    "(the runs follow)";

void addVersion(CLI::App& app) { app.set_version_flag("--version", kVersionText); }

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"PipeRun: pipe networks from laser scans of industrial plants.\n"
               "Exit codes: 0 ok, 1 usage, 2 bad input or output file, 3 internal error.",
               "piperun"};
  addVersion(app);
  app.require_subcommand(1);
  bool quiet = false;
  app.add_flag("-q,--quiet", quiet, "No progress bar on stderr")->configurable(false);

  InfoOptions info;
  auto* infoCommand = app.add_subcommand(
      "info", "Print a point cloud's point count, fields, bounding box and point spacing, or a network's summary");
  addVersion(*infoCommand);
  infoCommand
      ->add_option("file", info.input,
                   "Point cloud (.ply .pcd .xyz .txt .csv .pts .las .e57), network .json or project .piperun")
      ->required();
  piperun::app::addUnitsOption(*infoCommand, info.units);
  infoCommand->add_flag("--json", info.json, "Print the figures as JSON");
  infoCommand->add_flag("--runs", info.runs,
                        "For a network: each run's length, nominal size, pipes, elbows, tees and proposed elements");

  GenerateOptions generate;
  auto* generateCommand =
      app.add_subcommand("generate", "Generate a synthetic scanned plant scene with its ground-truth network");
  addVersion(*generateCommand);
  generateCommand->add_option("--preset", generate.preset, "Scene size: small (~300k points), medium (~2M), large (~20M)")
      ->check(CLI::IsMember({"small", "medium", "large"}))
      ->capture_default_str();
  generateCommand->add_option("--seed", generate.seed, "Random seed (same seed, same bytes)")->capture_default_str();
  generateCommand->add_option("-o,--output", generate.output, "Point cloud to write (.ply, .xyz, .txt or .csv)")
      ->required();
  generateCommand->add_option("--truth", generate.truth, "Ground-truth network to write (.json)");
  generateCommand->add_option("--noise", generate.noise, "Gaussian noise along the surface normal, metres")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  generateCommand->add_option("--outliers", generate.outliers, "Uniform outliers as a fraction of the points")
      ->check(CLI::Range(0.0, 10.0))
      ->capture_default_str();
  generateCommand->add_option("--stations", generate.stations, "Scanner stations 1-3 (0: chosen by the seed)")
      ->check(CLI::Range(0, 3))
      ->capture_default_str();
  generateCommand->add_option("--density", generate.density, "Scale of the scanner's sampling density (points)")
      ->check(CLI::Range(0.01, 100.0))
      ->capture_default_str();
  generateCommand->add_option("--registration-error", generate.registrationError,
                              "Misregistration of the stations after the first, metres: each is shifted by this "
                              "much and turned by this much per 10 m")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  generateCommand->add_option("--mixed-pixels", generate.mixedPixels,
                              "Share of the rays next to a depth edge that return a range between the two surfaces "
                              "(mixed pixels)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  piperun::app::addUpOption(*generateCommand, generate.up,
                             "Turn the scene so that this axis is up, points and truth (x, y, z, -x, -y or -z), as "
                             "a tool that writes y up gives a scan")
      ->capture_default_str();
  generateCommand->add_flag("--roof", generate.roof,
                            "Close the room with a concrete roof slab at its height (the pipes keep the points they "
                            "get without it)");
  generateCommand->add_flag("--labels", generate.labels,
                            "Also write each point's truth element id (label; 0 distractor, -1 outlier or mixed pixel)");

  EvalOptions eval;
  auto* evalCommand = app.add_subcommand("eval", "Compare a network with ground truth (precision, recall, F1)");
  addVersion(*evalCommand);
  evalCommand->add_option("truth", eval.truth, "Ground-truth network (.json, or a .piperun project's reviewed network)")
      ->required();
  evalCommand->add_option("result", eval.result, "Network to evaluate (.json, or a .piperun project's reviewed network)")
      ->required();
  evalCommand->add_flag("--json", eval.json, "Print the figures as JSON");
  evalCommand->add_flag("--pipes-only", eval.pipesOnly,
                        "Compare only the straight pipes of both networks (axis figures before joints)");
  evalCommand->add_option("--tolerance", eval.tolerance,
                          "Match distance in metres (default: max(0.02, half the truth radius))")
      ->check(CLI::PositiveNumber);
  evalCommand->add_option("--step", eval.step, "Axis sampling step in metres")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  evalCommand->add_option("--scan", eval.scan,
                          "The labelled scan the result came from (piperun generate --labels): also measure "
                          "recall over the truth the scan shows")
      ->check(CLI::ExistingFile);
  evalCommand->add_flag("--joints", eval.joints,
                        "Also list every truth elbow and tee (found or missed, with its pipes' labelled points given "
                        "--scan) and every spurious joint");

  ConvertOptions convert;
  auto* convertCommand = app.add_subcommand("convert", "Convert a point cloud to PLY or text, streaming");
  addVersion(*convertCommand);
  convertCommand->add_option("input", convert.input, "Point cloud to read")->required();
  convertCommand->add_option("output", convert.output, "Point cloud to write (.ply, .xyz, .txt, .csv)")->required();
  piperun::app::addUnitsOption(*convertCommand, convert.units);
  convertCommand->add_flag("--no-normals", convert.noNormals, "Leave normals out");
  convertCommand->add_flag("--no-colors", convert.noColors, "Leave colours out");
  convertCommand->add_flag("--no-intensity", convert.noIntensity, "Leave intensity out");
  convertCommand->add_flag("--no-labels", convert.noLabels, "Leave labels out");

  ReconstructOptions reconstruct;
  auto* reconstructCommand =
      app.add_subcommand("reconstruct", "Reconstruct the pipe network of a scan (prints a summary per stage)");
  addVersion(*reconstructCommand);
  reconstructCommand->add_option("scan", reconstruct.input, "Point cloud to reconstruct")->required();
  reconstructCommand->add_option("-o,--output", reconstruct.output, "Network to write (.json)")->required();
  piperun::app::addUnitsOption(*reconstructCommand, reconstruct.units);
  reconstructCommand->add_option("--params", reconstruct.paramsFile,
                                 "Parameter document (JSON, possibly partial; see `piperun params --json`)");
  reconstructCommand->add_option("--set", reconstruct.assignments,
                                 "Set one parameter, e.g. --set placement.max_radius=0.5 (repeatable)");
  reconstructCommand->add_option("--threads", reconstruct.threads, "Worker threads (default: all cores)")
      ->check(CLI::Range(1, 1024));
  reconstructCommand->add_option("--seed", reconstruct.seed, "Random seed (overrides the parameter document)")
      ->check(CLI::NonNegativeNumber);
  piperun::app::addUpOption(*reconstructCommand, reconstruct.up);
  reconstructCommand->add_option("--dump-stages", reconstruct.dumpDirectory,
                                 "Write every stage's output (labelled PLY clouds) into this folder");
  reconstructCommand->add_option("--truth", reconstruct.truth, "Ground-truth network: print the evaluation too");
  reconstructCommand->add_option("--until", reconstruct.until,
                                 "Last stage to run: merge (pipes only, no joints or runs) or joints (default)")
      ->check(CLI::IsMember({"merge", "joints"}));
  std::string formatNames;
  for (const std::string& name : piperun::exportFormatNames()) formatNames += (formatNames.empty() ? "" : " ") + name;
  reconstructCommand->add_option("--export", reconstruct.exports,
                                 "Also export the network, e.g. --export obj:net.obj (" + formatNames + "; repeatable)");
  reconstructCommand->add_option("--pcf-bore", reconstruct.pcfBore, kPcfBoreHelp)
      ->transform(CLI::IsMember({"nominal", "outside"}, CLI::ignore_case))
      ->capture_default_str();
  reconstructCommand->add_flag("--accepted-only", reconstruct.acceptedOnly, kAcceptedOnlyHelp);

  ExportCommandOptions exportOptions;
  auto* exportCommand =
      app.add_subcommand("export", "Export a network as a mesh (OBJ, PLY), table (CSV), CAD lines (DXF), PCF or IFC");
  addVersion(*exportCommand);
  exportCommand
      ->add_option("network", exportOptions.input, "Network to export (.json, or a .piperun project's reviewed network)")
      ->required();
  exportCommand->add_option("-o,--output", exportOptions.output, "File to write")->required();
  exportCommand->add_option("--format", exportOptions.format, formatNames + " (default: from the file name)")
      ->transform(CLI::IsMember(piperun::exportFormatNames(), CLI::ignore_case));
  exportCommand->add_option("--pcf-bore", exportOptions.pcfBore, kPcfBoreHelp)
      ->transform(CLI::IsMember({"nominal", "outside"}, CLI::ignore_case))
      ->capture_default_str();
  exportCommand->add_flag("--accepted-only", exportOptions.acceptedOnly, kAcceptedOnlyHelp);
  piperun::app::addUpOption(*exportCommand, exportOptions.up,
                             "The network's up axis, x, y, z, -x, -y or -z (default: the one `reconstruct --up` "
                             "recorded, else z): a PCF or IFC file is written turned so that it is z, as isometrics "
                             "draw elevations and IFC models stand");
  exportCommand->add_option("--chord-tolerance", exportOptions.chordTolerance,
                            "Meshes: largest gap between a tube's polygon and its circle, metres")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();

  ParamsOptions paramsOptions;
  auto* paramsCommand = app.add_subcommand("params", "Print every reconstruction parameter with its default");
  addVersion(*paramsCommand);
  paramsCommand->add_flag("--json", paramsOptions.json, "Print the defaults as a parameter document");
  paramsCommand->add_flag("--markdown", paramsOptions.markdown, "Print a Markdown table (docs/PARAMETERS.md)");

  if (const auto exitCode = piperun::app::parseArguments(app, argc, argv, "piperun")) return *exitCode;

  info.quiet = generate.quiet = convert.quiet = reconstruct.quiet = quiet;
  try {
    if (*infoCommand) return runInfo(info);
    if (*generateCommand) return runGenerate(generate);
    if (*evalCommand) return runEval(eval);
    if (*convertCommand) return runConvert(convert);
    if (*reconstructCommand) return runReconstruct(reconstruct);
    if (*paramsCommand) return runParams(paramsOptions);
    if (*exportCommand) return runExport(exportOptions);
  } catch (const piperun::InputError& error) {
    std::fprintf(stderr, "piperun: error: %s\n", error.what());
    return kExitBadInput;
  } catch (const piperun::OutputError& error) {
    std::fprintf(stderr, "piperun: error: %s\n", error.what());
    return kExitBadInput;
  } catch (const std::invalid_argument& error) {
    std::fprintf(stderr, "piperun: error: %s\n", error.what());
    return kExitUsage;
  } catch (const piperun::Cancelled&) {
    std::fprintf(stderr, "piperun: cancelled\n");
    return kExitInternal;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "piperun: internal error: %s\n", error.what());
    return kExitInternal;
  }
  return kExitUsage;
}
