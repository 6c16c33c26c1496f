// Writes an icosphere to an OM file and reads it back through vpffd::io
// (OM keeps float64, so the round trip is exact), then shows the error a
// corrupt file gives.
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "vpffd/io/mesh_io.h"
#include "vpffd/vpffd.h"

int main() {
  const vpffd::TriMesh sphere = vpffd::icosphere(3);
  const auto dir = std::filesystem::temp_directory_path();
  const std::string path = (dir / "vpffd_example_sphere.om").string();
  vpffd::write_mesh(path, sphere.V, sphere.F, vpffd::RowMatrixX3d(0, 3));
  const vpffd::MeshData back = vpffd::read_mesh(path);
  std::filesystem::remove(path);
  const bool same = back.V == sphere.V && back.F == sphere.F;
  std::printf("wrote and read %lld vertices, %lld triangles (%s): %s\n", static_cast<long long>(back.V.rows()),
              static_cast<long long>(back.F.rows()), back.format.c_str(), same ? "identical" : "DIFFERENT");

  const std::string bad = (dir / "vpffd_example_bad.off").string();
  std::ofstream(bad) << "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n";
  bool refused = false;
  try {
    vpffd::read_mesh(bad);
  } catch (const vpffd::MeshIOError& e) {
    std::printf("corrupt file: %s\n", e.what());
    refused = true;
  }
  std::filesystem::remove(bad);
  return same && refused ? 0 : 1;
}
