#pragma once
// Buffered line-by-line text input with line numbers and fast number parsing.

#include "piperun/error.h"

#include <charconv>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace piperun::io {

/// Reads a text file line by line (LF or CRLF). Lines are views into an internal buffer, valid
/// until the next call. Failures throw InputError naming the file and the line.
class TextLines {
 public:
  explicit TextLines(const std::filesystem::path& path);
  ~TextLines();
  TextLines(const TextLines&) = delete;
  TextLines& operator=(const TextLines&) = delete;

  /// The next line without its end-of-line characters; false at the end of the file.
  bool next(std::string_view& line);
  /// 1-based number of the line last returned by next().
  std::uint64_t lineNumber() const { return lineNumber_; }
  /// Bytes consumed so far, and the file size, for progress.
  std::uint64_t bytesConsumed() const { return consumed_; }
  std::uint64_t fileSize() const { return size_; }
  const std::filesystem::path& path() const { return path_; }

  /// Throws InputError at the current line.
  [[noreturn]] void fail(const std::string& message) const;

 private:
  bool refill();

  std::filesystem::path path_;
  std::FILE* file_ = nullptr;
  std::uint64_t size_ = 0;
  std::uint64_t consumed_ = 0;
  std::uint64_t lineNumber_ = 0;
  std::vector<char> buffer_;
  std::size_t begin_ = 0;  // first unread byte in buffer_
  std::size_t end_ = 0;    // one past the last valid byte in buffer_
  bool eof_ = false;
};

/// Splits a line into fields separated by spaces, tabs, commas or semicolons (runs of
/// whitespace count as one separator). Returns the number of fields (at most fields.size()
/// are stored; the count is the full number).
std::size_t splitFields(std::string_view line, std::vector<std::string_view>& fields);

/// Splits a header line into words separated by spaces, tabs or carriage returns.
std::vector<std::string_view> splitWords(std::string_view line);

/// A short, printable, quoted excerpt of text copied from a file into an error message.
std::string excerpt(std::string_view text);

/// Parses a whole field as a number; false when it is not one (trailing characters included).
bool parseNumber(std::string_view field, double& value);
bool parseNumber(std::string_view field, float& value);
bool parseNumber(std::string_view field, std::int64_t& value);

}  // namespace piperun::io
