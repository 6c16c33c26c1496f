// replace_file: see atomic_write.h. POSIX only (the project builds on Linux).

#include "atomic_write.h"

#include <fcntl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>

#include "io_util.h"

namespace fs = std::filesystem;

namespace vpffd::io_detail {
namespace {

std::string os_error(const char* op, int err) { return std::string(op) + ": " + std::strerror(err); }

/// Closes and removes the temporary unless released (any failure on the way).
struct Temporary {
  int fd = -1;
  std::string path;
  ~Temporary() {
    if (fd >= 0) ::close(fd);
    if (!path.empty()) ::unlink(path.c_str());
  }
};

const char* kind_of(mode_t m) {
  if (S_ISFIFO(m)) return "a FIFO (named pipe)";
  if (S_ISCHR(m)) return "a character device";
  if (S_ISBLK(m)) return "a block device";
  if (S_ISSOCK(m)) return "a socket";
  if (S_ISDIR(m)) return "a folder";
  return "not a regular file";
}

}  // namespace

void replace_file(const std::string& path, const std::string& shown, const std::string& bytes, const char* what) {
  // A link is followed: the file it names is replaced, and the link stays.
  std::string target = path;
  struct stat st {};
  bool exists = ::stat(path.c_str(), &st) == 0;
  if (!exists && errno != ENOENT)
    fail(what, shown, os_error("cannot look at the target", errno));
  if (exists && !S_ISREG(st.st_mode))
    fail(what, shown,
         std::string("is ") + kind_of(st.st_mode) +
             ", which cannot be replaced safely; write to a regular file");
  struct stat lst {};
  if (::lstat(path.c_str(), &lst) == 0 && S_ISLNK(lst.st_mode)) {
    std::error_code ec;
    const fs::path real = exists ? fs::canonical(path, ec) : fs::weakly_canonical(path, ec);
    if (ec) fail(what, shown, "cannot follow the symbolic link (" + ec.message() + ")");
    target = real.string();
  }
  // RLIMIT_FSIZE: a write past it raises SIGXFSZ, which ends a program that does not
  // ignore it; the size is known, so the limit is checked first.
  struct rlimit lim {};
  if (::getrlimit(RLIMIT_FSIZE, &lim) == 0 && lim.rlim_cur != RLIM_INFINITY &&
      static_cast<unsigned long long>(bytes.size()) > static_cast<unsigned long long>(lim.rlim_cur))
    fail(what, shown,
         "the file would take " + std::to_string(bytes.size()) + " bytes, more than this process's file-size limit (" +
             std::to_string(static_cast<unsigned long long>(lim.rlim_cur)) +
             " bytes, ulimit -f); nothing was written");

  const fs::path t(target);
  const fs::path dir = t.has_parent_path() ? t.parent_path() : fs::path(".");
  Temporary tmp;
  // An unpredictable name, created exclusively (O_EXCL) with the umask's permissions.
  std::mt19937_64 rng(static_cast<std::uint64_t>(std::chrono::steady_clock::now().time_since_epoch().count()) ^
                      reinterpret_cast<std::uintptr_t>(&tmp) ^ static_cast<std::uint64_t>(::getpid()));
  for (int attempt = 0; attempt < 100 && tmp.fd < 0; ++attempt) {
    char suffix[24];
    std::snprintf(suffix, sizeof suffix, ".%012llx.tmp", static_cast<unsigned long long>(rng() & 0xffffffffffffULL));
    const std::string name = (dir / ("." + t.filename().string() + suffix)).string();
    const int fd = ::open(name.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd >= 0) {
      tmp.fd = fd;
      tmp.path = name;
    } else if (errno != EEXIST) {
      fail(what, shown, os_error("cannot create a file in its folder", errno));
    }
  }
  if (tmp.fd < 0) fail(what, shown, "cannot create a temporary file in its folder");
  if (exists && ::fchmod(tmp.fd, st.st_mode & 07777) != 0)
    fail(what, shown, os_error("cannot give the new file the old one's permissions", errno));

  const char* p = bytes.data();
  std::size_t left = bytes.size();
  while (left > 0) {
    const ssize_t n = ::write(tmp.fd, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail(what, shown, os_error("write failed", errno) + "; the old file is unchanged");
    }
    if (n == 0) fail(what, shown, "write failed: no bytes written; the old file is unchanged");
    p += n;
    left -= static_cast<std::size_t>(n);
  }
  if (::fsync(tmp.fd) != 0) fail(what, shown, os_error("fsync failed", errno) + "; the old file is unchanged");
  const int fd = tmp.fd;
  tmp.fd = -1;
  if (::close(fd) != 0) fail(what, shown, os_error("close failed", errno) + "; the old file is unchanged");
  if (::rename(tmp.path.c_str(), target.c_str()) != 0)
    fail(what, shown, os_error("cannot replace the file", errno) + "; the old file is unchanged");
  tmp.path.clear();
  // The rename itself reaches the disk with the folder's entry (best effort: some
  // file systems do not sync folders).
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
}

}  // namespace vpffd::io_detail
