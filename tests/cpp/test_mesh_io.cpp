// vpffd::io on good and hostile files (the Python suite has the full set; these
// run under the C++ sanitizer build too).
#ifdef VPFFD_HAS_OPENMESH
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "vpffd/io/mesh_io.h"
#include "vpffd/vpffd.h"

namespace {

namespace fs = std::filesystem;

std::string temp_file(const std::string& name, const std::string& bytes) {
  const std::string p = (fs::temp_directory_path() / ("vpffd_test_" + name)).string();
  std::ofstream(p, std::ios::binary) << bytes;
  return p;
}

std::string error_of(const std::string& path) {
  try {
    vpffd::read_mesh(path);
  } catch (const vpffd::MeshIOError& e) {
    return e.what();
  }
  return "";
}

std::string u32(std::uint32_t v) {
  std::string s(4, '\0');
  for (int k = 0; k < 4; ++k) s[k] = static_cast<char>((v >> (8 * k)) & 0xFF);
  return s;
}

TEST(MeshIO, OmRoundTripIsExact) {
  const vpffd::TriMesh s = vpffd::icosphere(2);
  const std::string p = (fs::temp_directory_path() / "vpffd_test_rt.om").string();
  vpffd::write_mesh(p, s.V, s.F, vpffd::RowMatrixX3d(0, 3));
  const vpffd::MeshData d = vpffd::read_mesh(p);
  fs::remove(p);
  EXPECT_TRUE(d.V == s.V);
  EXPECT_TRUE(d.F == s.F);
}

TEST(MeshIO, BinaryOffCountsBeyondTheFileAreRefusedBeforeAllocating) {
  const std::string p = temp_file("huge.off", "OFF BINARY\n" + u32(0xFFFFFFFFu) + u32(1) + u32(0) + std::string(40, '\0'));
  const std::string e = error_of(p);
  fs::remove(p);
  EXPECT_NE(e.find("4294967295 vertices"), std::string::npos) << e;
}

TEST(MeshIO, OmFaceLoopOutOfRangeIsAnError) {
  // OM 2.0: 3 vertices, 1 face whose halfedge (99) does not exist.
  std::string om = std::string("OMT") + static_cast<char>(2 << 5) + u32(3) + u32(1) + u32(0);
  om += std::string("\x00\x14", 2);  // chunk: vertex positions, 3D float32 (bit 10 float, dim-1 = 2 at bit 11)
  om += std::string(36, '\0');
  om += std::string("\xE8\x80", 2);  // chunk: face topology (entity 2, type 7), 32-bit
  om += u32(99);
  const std::string p = temp_file("loop.om", om);
  const std::string e = error_of(p);
  fs::remove(p);
  EXPECT_NE(e.find("halfedge"), std::string::npos) << e;
}

TEST(MeshIO, NamesWithNulOrInvalidUtf8AreShownEscaped) {
  EXPECT_NE(error_of(std::string("a.obj\0.xyz", 10)).find("a.obj\\x00.xyz': the file name contains a NUL byte"),
            std::string::npos);
  EXPECT_NE(error_of("/nonexistent/m\xE9sh.ply").find("m\\xe9sh.ply': no such file"), std::string::npos);
}

}  // namespace
#endif
