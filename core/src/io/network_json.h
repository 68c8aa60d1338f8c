#pragma once
// Single pipes and joints in the piperun-network JSON form, for documents that embed them (project
// files store each edit's changed elements this way).

#include "piperun/pipe_network.h"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>

namespace piperun {

nlohmann::json pipeToJson(const Pipe& pipe);
nlohmann::json jointToJson(const Joint& joint);

/// Read one element; errors are InputErrors naming `source` and the JSON pointer of the bad value.
Pipe pipeFromJson(const nlohmann::json& object, const std::filesystem::path& source, const std::string& pointer);
Joint jointFromJson(const nlohmann::json& object, const std::filesystem::path& source, const std::string& pointer);

}  // namespace piperun
