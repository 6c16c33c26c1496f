#include "gzip.h"

#include <sys/resource.h>
#include <sys/statvfs.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <fstream>
#include <limits>
#include <sstream>
#include <vector>

#include "io_util.h"

namespace fs = std::filesystem;

namespace vpffd::io_detail {
namespace {

constexpr std::uint64_t kBytesPerInputByte = 16;

// Memory this process can still allocate, as far as it can tell: MemAvailable,
// and the room left under RLIMIT_AS when one is set.
std::uint64_t memory_left() {
  const auto page = static_cast<std::uint64_t>(sysconf(_SC_PAGESIZE));
  std::uint64_t left = static_cast<std::uint64_t>(sysconf(_SC_PHYS_PAGES)) * page;
  std::ifstream meminfo("/proc/meminfo");
  for (std::string key; meminfo >> key;) {
    std::uint64_t kib = 0;
    if (key == "MemAvailable:" && meminfo >> kib) {
      left = std::min(left, kib * 1024);
      break;
    }
    meminfo.ignore(std::numeric_limits<std::streamsize>::max(), '\n');
  }
  rlimit as{};
  if (getrlimit(RLIMIT_AS, &as) == 0 && as.rlim_cur != RLIM_INFINITY) {
    std::uint64_t mapped_pages = 0;
    std::ifstream statm("/proc/self/statm");
    statm >> mapped_pages;
    const std::uint64_t mapped = mapped_pages * page;
    const auto cap = static_cast<std::uint64_t>(as.rlim_cur);
    left = std::min(left, cap > mapped ? cap - mapped : 0);
  }
  return left;
}

std::string mib(std::uint64_t bytes) {
  std::ostringstream s;
  s.precision(3);
  s << static_cast<double>(bytes) / (1 << 20) << " MiB";
  return s.str();
}

}  // namespace

std::uint64_t gunzip_limit(const fs::path& temp_dir) {
  std::uint64_t limit = memory_left() / kBytesPerInputByte;
  struct statvfs vfs {};
  if (statvfs(temp_dir.c_str(), &vfs) == 0)
    limit = std::min(limit, static_cast<std::uint64_t>(vfs.f_bavail) * vfs.f_frsize);
  return limit;
}

GunzipTemp::GunzipTemp(const std::string& path, const std::string& shown, const std::string& inner_ext) {
  const char* what = "load_mesh";
  gzFile in = gzopen(path.c_str(), "rb");
  if (!in) fail(what, shown, "cannot open the gzip file");
  static std::atomic<unsigned> counter{0};
  const auto stamp = std::chrono::steady_clock::now().time_since_epoch().count();
  std::error_code ec;
  const fs::path dir = fs::temp_directory_path(ec);
  if (ec) {
    gzclose(in);
    fail(what, shown, "no temporary folder to decompress into (" + ec.message() + ")");
  }
  const std::uint64_t limit = gunzip_limit(dir);
  tmp_ = dir / ("vpffd-" + std::to_string(getpid()) + "-" + std::to_string(stamp) + "-" +
                std::to_string(counter++) + "." + inner_ext);
  std::ofstream out(tmp_, std::ios::binary);
  auto give_up = [&](const std::string& why) {
    gzclose(in);
    out.close();
    std::error_code e;
    fs::remove(tmp_, e);
    fail(what, shown, why);
  };
  if (!out) give_up("cannot create a temporary file to decompress into");
  std::vector<char> buf(1 << 20);
  for (;;) {
    const int n = gzread(in, buf.data(), static_cast<unsigned>(buf.size()));
    if (n < 0) {
      int err = 0;
      give_up("gzip data is corrupt or truncated (" + printable(gzerror(in, &err)) + ")");
    }
    if (n == 0) break;
    bytes_ += static_cast<std::uint64_t>(n);
    if (bytes_ > limit)
      give_up("decompresses to more than " + mib(limit) +
              ", the most this process can read (1/16 of the memory it can still allocate, or the free space "
              "of the temporary folder): a gzip bomb, or a mesh too large for this machine");
    out.write(buf.data(), n);
    if (!out) give_up("cannot write the temporary file (disk full?)");
  }
  // gzread stops silently at a truncated stream; gzclose reports it.
  const int rc = gzclose(in);
  out.close();
  if (rc != Z_OK || !out) {
    std::error_code e;
    fs::remove(tmp_, e);
    fail(what, shown, rc != Z_OK ? "gzip data is corrupt or truncated" : "cannot write the temporary file");
  }
}

GunzipTemp::~GunzipTemp() {
  std::error_code ec;
  fs::remove(tmp_, ec);
}

}  // namespace vpffd::io_detail
