#include "piperun/error.h"

namespace piperun {

namespace {
std::string composeMessage(const std::filesystem::path& file, const std::string& location,
                           const std::string& message) {
  std::string text = file.string();
  if (!location.empty()) text += ": " + location;
  text += ": " + message;
  // One line, whatever the message carries (XML snippets, file names with newlines).
  for (char& c : text) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  return text;
}
}  // namespace

InputError::InputError(const std::filesystem::path& file, const std::string& location, const std::string& message)
    : std::runtime_error(composeMessage(file, location, message)),
      file_(file.string()),
      location_(location),
      message_(message) {}

std::string byteLocation(std::uint64_t offset) { return "byte " + std::to_string(offset); }
std::string lineLocation(std::uint64_t line) { return "line " + std::to_string(line); }

}  // namespace piperun
