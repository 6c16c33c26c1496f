// A build without OpenMesh: every format is read and written by vpffd itself but
// for writing OM, which stores OpenMesh's halfedge connectivity and is therefore
// left to OpenMesh; it is refused with the package to install.

#include "readers.h"
#include "vpffd/core/exceptions.h"

namespace vpffd::io_detail {

WriteReport write_om(const std::string&, const std::string& shown, const ConstV&, const ConstF&, const ConstV&) {
  throw BackendUnavailableError("save_mesh: '" + shown +
                                "': writing .om files needs OpenMesh, which this build of vpffd was compiled "
                                "without (Debian/Ubuntu: apt-get install libopenmesh-dev, then rebuild vpffd). "
                                "Every format, .om included, can be read without it, and .obj, .off, .ply and "
                                ".stl files written.");
}

}  // namespace vpffd::io_detail
