#pragma once
// Replacing a file without ever losing it (internal; see mesh_io.cpp): the new
// bytes go to a temporary file in the target's folder, every write and the close
// are checked, the data is flushed to the disk (fsync), and only then is the
// temporary renamed over the target. A write that fails (a full disk, a file-size
// limit, an I/O error) leaves the old file as it was and no temporary behind.

#include <string>

namespace vpffd::io_detail {

/// Replaces `path` (a new file, or an existing regular file, or a symbolic link to
/// one, which stays a link) by `bytes`. Throws MeshIOError "what: 'shown': why" for a
/// target that is not a regular file (a FIFO, a device, a socket, a folder), a
/// folder that does not exist or cannot be written, a file larger than the
/// process's file-size limit (RLIMIT_FSIZE), and any failed write, fsync, close or
/// rename, naming the operating system's error. A new file gets the permissions
/// the process's umask gives; an existing one keeps its own.
void replace_file(const std::string& path, const std::string& shown, const std::string& bytes, const char* what);

}  // namespace vpffd::io_detail
