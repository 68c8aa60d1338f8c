#include "io/binary_file.h"

#include <cerrno>

namespace piperun::io {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "the readers assume a little-endian host");

namespace {
constexpr std::size_t kBufferBytes = 1u << 20;
}

BinaryFile::BinaryFile(const std::filesystem::path& path) : path_(path) {
  std::error_code error;
  if (std::filesystem::is_directory(path, error)) throw InputError(path, "", "is a directory, expected a file");
  file_ = std::fopen(path.c_str(), "rb");
  if (!file_) throw InputError(path, "", std::string("cannot open: ") + std::strerror(errno));
  std::setvbuf(file_, nullptr, _IOFBF, kBufferBytes);
  const auto size = std::filesystem::file_size(path, error);
  if (error) throw InputError(path, "", "cannot read its size: " + error.message());
  size_ = size;
}

BinaryFile::~BinaryFile() {
  if (file_) std::fclose(file_);
}

void BinaryFile::seek(std::uint64_t offset, const char* what) {
  if (offset > size_) {
    fail("offset " + std::to_string(offset) + " of " + what + " lies beyond the end of the file (" +
         std::to_string(size_) + " bytes)");
  }
  if (fseeko(file_, static_cast<off_t>(offset), SEEK_SET) != 0) failAt(offset, "cannot seek");
  offset_ = offset;
}

void BinaryFile::read(void* destination, std::size_t n, const char* what) {
  const std::size_t got = std::fread(destination, 1, n, file_);
  if (got != n) {
    const auto at = offset_;
    offset_ += got;
    failAt(at, "unexpected end of file, expected " + std::to_string(n) + " bytes of " + what);
  }
  offset_ += n;
}

std::size_t BinaryFile::readSome(void* destination, std::size_t n) {
  const std::size_t got = std::fread(destination, 1, n, file_);
  offset_ += got;
  return got;
}

void BinaryFile::fail(const std::string& message) const { failAt(offset_, message); }

void BinaryFile::failAt(std::uint64_t offset, const std::string& message) const {
  throw InputError(path_, byteLocation(offset), message);
}

}  // namespace piperun::io
