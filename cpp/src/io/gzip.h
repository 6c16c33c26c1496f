#pragma once
// Gzip-compressed mesh files: decompressed to a temporary file, with a bound
// on the decompressed size (a "gzip bomb" of a few kilobytes can expand to
// gigabytes). Internal to vpffd::io.

#include <cstdint>
#include <filesystem>
#include <string>

namespace vpffd::io_detail {

/// The most bytes a .gz input may decompress to: 1/16 of the memory this
/// process can still get (the smallest of MemAvailable and the room left under
/// RLIMIT_AS), because the readers hold up to about 16 bytes per input byte
/// (an OBJ fan "f 1 2 3 4 ..." turns 2 bytes per corner into one 12-byte
/// triangle, kept twice while the vector grows, plus the returned matrix), and
/// at most the free space of the temporary folder.
std::uint64_t gunzip_limit(const std::filesystem::path& temp_dir);

/// Decompresses `path` into a temporary file ending in "." + inner_ext, removed
/// on destruction. Throws MeshIOError (naming `shown`) for a corrupt or
/// truncated stream or a decompressed size above gunzip_limit().
class GunzipTemp {
 public:
  GunzipTemp(const std::string& path, const std::string& shown, const std::string& inner_ext);
  ~GunzipTemp();
  GunzipTemp(const GunzipTemp&) = delete;
  GunzipTemp& operator=(const GunzipTemp&) = delete;
  std::string path() const { return tmp_.string(); }
  std::uint64_t bytes() const { return bytes_; }

 private:
  std::filesystem::path tmp_;
  std::uint64_t bytes_ = 0;
};

}  // namespace vpffd::io_detail
