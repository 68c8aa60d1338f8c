#pragma once
// Networks and single pipes and joints in the piperun-network JSON form, as values for documents
// that embed them (project files hold two networks and each edit's changed elements).

#include "piperun/io/network_io.h"
#include "piperun/pipe_network.h"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>

namespace piperun {

nlohmann::json networkToJsonValue(const PipeNetwork& network, const NetworkMetadata& metadata = {});
/// As networkFromJson(); error locations are JSON pointers within `document`.
PipeNetwork networkFromJsonValue(const nlohmann::json& document, const std::filesystem::path& source,
                                 NetworkMetadata* metadata = nullptr);

nlohmann::json pipeToJson(const Pipe& pipe);
nlohmann::json jointToJson(const Joint& joint);

/// Read one element; errors are InputErrors naming `source` and the JSON pointer of the bad value.
Pipe pipeFromJson(const nlohmann::json& object, const std::filesystem::path& source, const std::string& pointer);
Joint jointFromJson(const nlohmann::json& object, const std::filesystem::path& source, const std::string& pointer);

}  // namespace piperun
