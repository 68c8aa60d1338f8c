#pragma once
// Parsing a JSON document read from a file, with the syntax error reported as the project's
// readers report theirs: an InputError naming the file and the byte.

#include "piperun/error.h"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>

namespace piperun {

/// `Json` is nlohmann::json or nlohmann::ordered_json.
template <class Json>
Json parseJsonText(const std::string& text, const std::filesystem::path& source) {
  try {
    return Json::parse(text);
  } catch (const typename Json::parse_error& error) {
    // nlohmann's message starts with its own "[json.exception.parse_error.101] parse error at ...".
    std::string message = error.what();
    if (const auto colon = message.find(": "); colon != std::string::npos) message = message.substr(colon + 2);
    // nlohmann counts bytes from 1; the other readers report 0-based offsets.
    throw InputError(source, byteLocation(error.byte > 0 ? error.byte - 1 : 0), "invalid JSON: " + message);
  } catch (const typename Json::out_of_range& error) {
    // A number beyond a double's range ("number overflow parsing '1e999'"); nlohmann gives no byte.
    std::string message = error.what();
    if (const auto bracket = message.find("] "); bracket != std::string::npos) message = message.substr(bracket + 2);
    throw InputError(source, "", "invalid JSON: " + message);
  }
}

}  // namespace piperun
