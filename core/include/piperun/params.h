#pragma once
// All pipeline parameters as one JSON document, with a one-line description of each.

#include "piperun/pipeline.h"

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace piperun {

struct ParamDescription {
  std::string key;           ///< "placement.maxRadius"
  std::string defaultValue;  ///< As JSON text.
  std::string unit;          ///< "m", "deg", "" ...
  std::string range;         ///< The values accepted: "> 0", ">= 3", "[0, 1]", "(0, 30]"; empty for any.
  std::string description;   ///< One line.
};

/// Every parameter, in document order.
std::vector<ParamDescription> describeParams();

/// The parameters as a JSON document {"seed":…, "rounds":…, "preprocess":{…}, …}.
std::string paramsToJson(const PipelineParams& params, int indent = 2);

/// Reads a (possibly partial) parameter document on top of `base`: keys it leaves out keep their
/// value from `base`. Unknown keys, values of the wrong type and values outside a parameter's range
/// are InputErrors naming the key.
PipelineParams paramsFromJson(const std::string& text, const std::filesystem::path& source,
                              const PipelineParams& base = {});
PipelineParams readParams(const std::filesystem::path& path, const PipelineParams& base = {});

/// The earliest stage whose parameters differ between `a` and `b` (seed and rounds belong to the
/// directions stage, the first per-tile stage); nullopt when they are equal, or differ only in
/// parameters that change no result (preprocess.kept_neighbors_mb).
std::optional<Stage> firstChangedStage(const PipelineParams& a, const PipelineParams& b);

/// Applies one "section.key=value" assignment (as typed on a command line or in a script);
/// throws std::invalid_argument naming the key when it is unknown, the value does not parse or it
/// lies outside the parameter's range (`params` is then left as it was).
void setParam(PipelineParams& params, const std::string& assignment);

/// Checks every parameter against its range and the pairs that bound each other (min_radius below
/// max_radius, ...); throws std::invalid_argument naming every offending key.
void validateParams(const PipelineParams& params);

}  // namespace piperun
