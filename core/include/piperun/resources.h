#pragma once
// Data files shipped in resources/ (nominal pipe sizes, ...), found at run time.

#include <filesystem>
#include <string>

namespace piperun {

/// The path of the shipped data file `name`, looked up in order: the folder named by the
/// PIPERUN_RESOURCE_DIR environment variable; share/piperun beside the running executable's bin/
/// folder (an installed or relocated package); the install prefix's share/piperun; the source
/// tree's resources/ (build trees). Throws InputError naming the folders searched when it is in none.
std::filesystem::path findResource(const std::string& name);

}  // namespace piperun
