// Replays files through the C++ mesh readers: `vpffd_fuzz_replay FILE|DIR...`.
// Each file must give a valid mesh or a vpffd::MeshIOError that names it;
// anything else (another exception, a crash, a sanitizer report) is a finding.
// Built with the C++ tests; run under AddressSanitizer + UBSan by
// scripts/sanitize.sh on the corpus tests/fuzz/fuzz_io.py --keep writes, so the
// readers' memory safety is checked below the Python layer the fuzzer sees.

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "vpffd/core/exceptions.h"
#include "vpffd/io/mesh_io.h"

namespace fs = std::filesystem;

namespace {

// Empty when the mesh is valid, else what is wrong with it.
std::string invalid(const vpffd::MeshData& m) {
  if (m.V.rows() == 0 || m.F.rows() == 0) return "empty mesh without an error";
  if (!m.V.allFinite()) return "non-finite vertex";
  if (m.F.minCoeff() < 0 || m.F.maxCoeff() >= m.V.rows()) return "face index out of range";
  if (m.N.rows() != 0 && m.N.rows() != m.V.rows()) return "normals do not match the vertices";
  return {};
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<fs::path> files;
  for (int i = 1; i < argc; ++i) {
    const fs::path p(argv[i]);
    if (fs::is_directory(p)) {
      for (const auto& e : fs::recursive_directory_iterator(p))
        if (e.is_regular_file()) files.push_back(e.path());
    } else {
      files.push_back(p);
    }
  }
  if (files.empty()) {
    std::fprintf(stderr, "usage: vpffd_fuzz_replay FILE|DIR...  (no files given)\n");
    return 2;
  }
  long ok = 0, refused = 0, findings = 0;
  for (const auto& f : files) {
    const std::string name = f.string();
    try {
      const std::string why = invalid(vpffd::read_mesh(name));
      if (why.empty()) {
        ++ok;
      } else {
        ++findings;
        std::printf("FINDING %s: %s\n", name.c_str(), why.c_str());
      }
    } catch (const vpffd::MeshIOError& e) {
      const std::string msg = e.what();
      if (msg.find(f.filename().string()) == std::string::npos) {
        ++findings;
        std::printf("FINDING %s: MeshIOError without the file name: %s\n", name.c_str(), msg.c_str());
      } else {
        ++refused;
      }
    } catch (const std::exception& e) {
      ++findings;
      std::printf("FINDING %s: %s\n", name.c_str(), e.what());
    }
  }
  std::printf("%zu files: %ld meshes, %ld MeshIOError, %ld findings\n", files.size(), ok, refused, findings);
  return findings ? 1 : 0;
}
