// A build without OpenMesh: vpffd's own readers (OBJ, OFF, PLY, OM) still work,
// and what only OpenMesh does here (reading STL, writing any format) is refused
// with the package to install, instead of the whole of vpffd::io being left out.

#include "readers.h"
#include "vpffd/core/exceptions.h"

namespace vpffd::io_detail {
namespace {

[[noreturn]] void refuse(const char* what, const std::string& shown, const std::string& doing) {
  throw BackendUnavailableError(std::string(what) + ": '" + shown + "': " + doing +
                                " needs OpenMesh, which this build of vpffd was compiled without "
                                "(Debian/Ubuntu: apt-get install libopenmesh-dev, then rebuild vpffd). "
                                "OBJ, OFF, PLY and OM files can be read without it.");
}

}  // namespace

void read_with_openmesh(const std::string&, const std::string& shown, const std::string& ext, MeshData&) {
  refuse("load_mesh", shown, "reading ." + ext + " files");
}

WriteReport write_with_openmesh(const std::string&, const std::string& shown, const std::string& ext,
                                const Eigen::Ref<const RowMatrixX3d>&, const Eigen::Ref<const RowMatrixX3i>&,
                                const Eigen::Ref<const RowMatrixX3d>&, const WriteOptions&) {
  refuse("save_mesh", shown, "writing ." + ext + " files");
}

}  // namespace vpffd::io_detail
