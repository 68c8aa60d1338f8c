#pragma once
// The piperun-network JSON format (docs/FORMATS.md): reading and writing pipe networks.

#include "piperun/pipe_network.h"
#include "piperun/up_axis.h"

#include <filesystem>
#include <map>
#include <string>

namespace piperun {

constexpr const char* kNetworkFormatName = "piperun-network";
constexpr int kNetworkFormatVersion = 1;

/// Free-form key/value pairs stored under "metadata" (generator settings, source scan, tool version).
using NetworkMetadata = std::map<std::string, std::string>;

/// The network as a JSON document (pretty-printed with `indent` spaces; -1 for one line).
std::string networkToJson(const PipeNetwork& network, const NetworkMetadata& metadata = {}, int indent = 1);

/// Parses a piperun-network document. `source` names the document in errors. Throws InputError
/// whose location is the byte offset (syntax) or the JSON pointer of the offending value
/// (e.g. "/pipes/3/radius"); unknown versions are rejected with the supported one named.
PipeNetwork networkFromJson(const std::string& text, const std::filesystem::path& source,
                            NetworkMetadata* metadata = nullptr);

/// Writes atomically: a temporary file beside `path` is written, flushed and renamed over it.
void writeNetwork(const std::filesystem::path& path, const PipeNetwork& network,
                  const NetworkMetadata& metadata = {});

PipeNetwork readNetwork(const std::filesystem::path& path, NetworkMetadata* metadata = nullptr);
/// Records `up` in a network's `metadata` ("up"), unless it is z, which a network without the key has.
void recordUpAxis(NetworkMetadata& metadata, UpAxis up);
/// The up axis a network's `metadata` records (recordUpAxis), z when it records none. Throws
/// InputError (at /metadata/up of `source`) for an unknown axis.
UpAxis recordedUpAxis(const NetworkMetadata& metadata, const std::filesystem::path& source);
/// Whether the path names a network file (`.json`, any case).
bool isNetworkFile(const std::filesystem::path& path);

/// Total axis length of a run's pipes and joints (m).
double runLength(const PipeNetwork& network, const Run& run);
/// The radius that covers the largest share of a run's length (its nominal size).
double runNominalRadius(const PipeNetwork& network, const Run& run);

}  // namespace piperun
