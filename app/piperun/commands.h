#pragma once
// The subcommands of `piperun`; each returns the process exit code (see docs/CLI.md).

#include <cstdint>
#include <string>
#include <vector>

namespace piperun::cli {

enum ExitCode { kExitOk = 0, kExitUsage = 1, kExitBadInput = 2, kExitInternal = 3 };

struct InfoOptions {
  std::string input;
  std::string units;        ///< The scan's coordinate unit (lengthUnitNames()); empty: the file's own, else m.
  bool json = false;
  bool runs = false;  ///< For a network: one line per run.
  bool quiet = false;
};
int runInfo(const InfoOptions& options);

struct GenerateOptions {
  std::string preset = "small";
  std::uint64_t seed = 1;
  std::string output;
  std::string truth;
  double noise = 0.002;
  double outliers = 0.01;
  int stations = 0;
  double density = 1.0;
  double registrationError = 0.0;
  double mixedPixels = 0.0;
  std::string up = "z";
  bool roof = false;
  bool labels = false;
  bool quiet = false;
};
int runGenerate(const GenerateOptions& options);

struct EvalOptions {
  std::string truth;
  std::string result;
  bool json = false;
  double tolerance = 0.0;
  double step = 0.01;
  bool pipesOnly = false;
  std::string scan;  ///< Labelled scan: adds the observable-recall figures.
  bool joints = false;  ///< List every truth elbow and tee and every spurious joint.
};
int runEval(const EvalOptions& options);

struct ConvertOptions {
  std::string input;
  std::string output;
  std::string units;        ///< The input's coordinate unit (empty: its own, else m); the output is in metres.
  bool noNormals = false;
  bool noColors = false;
  bool noIntensity = false;
  bool noLabels = false;
  bool quiet = false;
};
int runConvert(const ConvertOptions& options);

struct ReconstructOptions {
  std::string input;
  std::string output;
  std::string units;                     ///< The scan's coordinate unit; empty: the file's own, else m.
  std::string paramsFile;
  std::vector<std::string> assignments;  ///< "section.key=value"
  int threads = 0;                       ///< 0: all cores
  std::int64_t seed = -1;                ///< -1: from the parameters
  std::string up;                        ///< Empty: from the parameters
  std::string dumpDirectory;
  std::string truth;                     ///< Optional: evaluate against this network.
  std::string until = "joints";          ///< Last stage to run: "merge" or "joints".
  std::vector<std::string> exports;      ///< "FORMAT:FILE", written after the network.
  std::string pcfBore = "nominal";       ///< PCF exports' bores: "nominal" or "outside".
  bool acceptedOnly = false;             ///< Exports leave out what is proposed (acceptedPart).
  bool quiet = false;
};
int runReconstruct(const ReconstructOptions& options);

struct ExportCommandOptions {
  std::string input;
  std::string output;
  std::string format;             ///< Empty: from the output's extension.
  double chordTolerance = 0.001;  ///< Mesh tessellation, metres.
  std::string pcfBore = "nominal";  ///< PCF bores: "nominal" or "outside".
  bool acceptedOnly = false;        ///< Leave out what is proposed and the joints on it (acceptedPart).
  std::string up;                   ///< The network's up axis; empty: the one it records, else z.
};
int runExport(const ExportCommandOptions& options);

struct ParamsOptions {
  bool json = false;
  bool markdown = false;
};
int runParams(const ParamsOptions& options);

}  // namespace piperun::cli
