#pragma once
// Buffered binary file input with byte-offset tracking and uniform error messages.

#include "piperun/error.h"

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <type_traits>

namespace piperun::io {

/// A read-only binary file. Every failure throws InputError naming the file and a byte offset.
class BinaryFile {
 public:
  explicit BinaryFile(const std::filesystem::path& path);
  ~BinaryFile();
  BinaryFile(const BinaryFile&) = delete;
  BinaryFile& operator=(const BinaryFile&) = delete;

  const std::filesystem::path& path() const { return path_; }
  std::uint64_t size() const { return size_; }
  std::uint64_t tell() const { return offset_; }
  std::uint64_t remaining() const { return size_ - offset_; }

  /// Moves to an absolute offset; `what` names what is expected there, for the error message
  /// when the offset lies beyond the end of the file.
  void seek(std::uint64_t offset, const char* what);
  /// Reads exactly n bytes; on a short file throws "byte X: unexpected end of file, expected
  /// <n> bytes of <what>".
  void read(void* destination, std::size_t n, const char* what);
  /// Reads up to n bytes; returns the count (0 at the end).
  std::size_t readSome(void* destination, std::size_t n);

  /// Reads a little-endian (or big-endian) arithmetic value.
  template <class T>
  T readLE(const char* what) {
    static_assert(std::is_arithmetic_v<T>);
    T value;
    read(&value, sizeof(T), what);
    return value;  // x86-64 and arm64 are little-endian; see static_assert in binary_file.cpp.
  }

  /// Throws InputError at the current offset (or at `offset`).
  [[noreturn]] void fail(const std::string& message) const;
  [[noreturn]] void failAt(std::uint64_t offset, const std::string& message) const;

 private:
  std::filesystem::path path_;
  std::FILE* file_ = nullptr;
  std::uint64_t size_ = 0;
  std::uint64_t offset_ = 0;
};

/// Byte-order helpers for decoding buffers.
template <class T>
T loadLE(const void* bytes) {
  T value;
  std::memcpy(&value, bytes, sizeof(T));
  return value;
}

template <class T>
T loadBE(const void* bytes) {
  unsigned char swapped[sizeof(T)];
  const auto* source = static_cast<const unsigned char*>(bytes);
  for (std::size_t i = 0; i < sizeof(T); ++i) swapped[i] = source[sizeof(T) - 1 - i];
  T value;
  std::memcpy(&value, swapped, sizeof(T));
  return value;
}

}  // namespace piperun::io
