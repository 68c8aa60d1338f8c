#pragma once
// Errors with a clear one-line message: the file, the place in it and what was expected.

#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>

namespace piperun {

/// A problem with an input file (malformed, truncated, unsupported). The command-line tool maps it
/// to exit code 2. what() is one line: "<file>: <location>: <message>" (location may be empty).
class InputError : public std::runtime_error {
 public:
  InputError(const std::filesystem::path& file, const std::string& location, const std::string& message);

  const std::string& file() const { return file_; }
  const std::string& location() const { return location_; }
  const std::string& message() const { return message_; }

 private:
  std::string file_;
  std::string location_;
  std::string message_;
};

/// A file that cannot be written (cannot create, disk full). The command-line tool maps it to exit
/// code 2. what() is one line: "<file>: <message>".
class OutputError : public std::runtime_error {
 public:
  OutputError(const std::filesystem::path& file, const std::string& message)
      : std::runtime_error(file.string() + ": " + message) {}
};

/// "byte 1234" (for binary formats).
std::string byteLocation(std::uint64_t offset);
/// "line 12" (for text formats).
std::string lineLocation(std::uint64_t line);

/// Raised by a long operation when its Progress was cancelled.
class Cancelled : public std::runtime_error {
 public:
  Cancelled() : std::runtime_error("cancelled") {}
};

}  // namespace piperun
