#include "io/text_lines.h"

#include <cerrno>
#include <cstring>

namespace piperun::io {

namespace {
constexpr std::size_t kBlockBytes = 1u << 20;
// A line longer than this is not a point record: fail instead of growing without bound.
constexpr std::size_t kMaxLineBytes = 1u << 20;

bool isSeparator(char c) { return c == ' ' || c == '\t' || c == ',' || c == ';' || c == '\r'; }
}  // namespace

TextLines::TextLines(const std::filesystem::path& path) : path_(path) {
  std::error_code error;
  if (std::filesystem::is_directory(path, error)) throw InputError(path, "", "is a directory, expected a file");
  file_ = std::fopen(path.c_str(), "rb");
  if (!file_) throw InputError(path, "", std::string("cannot open: ") + std::strerror(errno));
  const auto size = std::filesystem::file_size(path, error);
  size_ = error ? 0 : size;
  buffer_.resize(kBlockBytes);
}

TextLines::~TextLines() {
  if (file_) std::fclose(file_);
}

bool TextLines::refill() {
  if (eof_) return false;
  // Keep the unread tail, then top up the buffer.
  const std::size_t tail = end_ - begin_;
  if (begin_ > 0 && tail > 0) std::memmove(buffer_.data(), buffer_.data() + begin_, tail);
  begin_ = 0;
  end_ = tail;
  if (end_ == buffer_.size()) {
    if (buffer_.size() >= kMaxLineBytes + kBlockBytes) {
      lineNumber_ += 1;
      fail("line longer than " + std::to_string(kMaxLineBytes) + " bytes, expected one point per line");
    }
    buffer_.resize(buffer_.size() + kBlockBytes);
  }
  const std::size_t got = std::fread(buffer_.data() + end_, 1, buffer_.size() - end_, file_);
  if (got == 0) {
    eof_ = true;
    return false;
  }
  end_ += got;
  return true;
}

bool TextLines::next(std::string_view& line) {
  for (;;) {
    const char* start = buffer_.data() + begin_;
    const auto* newline = static_cast<const char*>(std::memchr(start, '\n', end_ - begin_));
    if (newline) {
      std::size_t length = static_cast<std::size_t>(newline - start);
      consumed_ += length + 1;
      begin_ += length + 1;
      if (length > 0 && start[length - 1] == '\r') --length;
      line = std::string_view(start, length);
      ++lineNumber_;
      return true;
    }
    if (!refill()) {
      if (begin_ == end_) return false;
      // Last line without a newline.
      const char* last = buffer_.data() + begin_;
      std::size_t length = end_ - begin_;
      consumed_ += length;
      begin_ = end_;
      if (length > 0 && last[length - 1] == '\r') --length;
      line = std::string_view(last, length);
      ++lineNumber_;
      return true;
    }
  }
}

void TextLines::fail(const std::string& message) const {
  throw InputError(path_, lineLocation(lineNumber_), message);
}

std::size_t splitFields(std::string_view line, std::vector<std::string_view>& fields) {
  std::size_t count = 0;
  std::size_t i = 0;
  const std::size_t n = line.size();
  while (i < n) {
    while (i < n && isSeparator(line[i])) ++i;
    if (i >= n) break;
    const std::size_t start = i;
    while (i < n && !isSeparator(line[i])) ++i;
    if (count < fields.size()) fields[count] = line.substr(start, i - start);
    ++count;
  }
  return count;
}

std::vector<std::string_view> splitWords(std::string_view line) {
  std::vector<std::string_view> result;
  std::size_t i = 0;
  const auto blank = [](char c) { return c == ' ' || c == '\t' || c == '\r'; };
  while (i < line.size()) {
    while (i < line.size() && blank(line[i])) ++i;
    const std::size_t start = i;
    while (i < line.size() && !blank(line[i])) ++i;
    if (i > start) result.push_back(line.substr(start, i - start));
  }
  return result;
}

std::string excerpt(std::string_view text) {
  constexpr std::size_t kShown = 40;
  std::string shown(text.substr(0, kShown));
  for (char& c : shown) {
    if (static_cast<unsigned char>(c) < 32 || static_cast<unsigned char>(c) > 126) c = '?';
  }
  return "'" + shown + (text.size() > kShown ? "...'" : "'");
}

namespace {
template <class T>
bool parseFloating(std::string_view field, T& value) {
  if (!field.empty() && field.front() == '+') field.remove_prefix(1);
  const char* first = field.data();
  const char* last = field.data() + field.size();
  const auto result = std::from_chars(first, last, value);
  return result.ec == std::errc() && result.ptr == last;
}
}  // namespace

bool parseNumber(std::string_view field, double& value) { return parseFloating(field, value); }
bool parseNumber(std::string_view field, float& value) { return parseFloating(field, value); }

bool parseNumber(std::string_view field, std::int64_t& value) {
  if (!field.empty() && field.front() == '+') field.remove_prefix(1);
  const char* last = field.data() + field.size();
  const auto result = std::from_chars(field.data(), last, value);
  return result.ec == std::errc() && result.ptr == last;
}

}  // namespace piperun::io
