// vpffd::io on good and hostile files (the Python suite has the full set; these
// run under the C++ sanitizer build too).
#ifdef VPFFD_HAS_MESH_IO
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include "vpffd/io/mesh_io.h"
#include "vpffd/vpffd.h"

// Named, not anonymous: the tests are compiled in unity batches.
namespace mesh_io_test {

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

#ifdef VPFFD_HAS_OPENMESH
TEST(MeshIO, OmRoundTripIsExact) {
  const vpffd::TriMesh s = vpffd::icosphere(2);
  const std::string p = (fs::temp_directory_path() / "vpffd_test_rt.om").string();
  vpffd::write_mesh(p, s.V, s.F, vpffd::RowMatrixX3d(0, 3));
  const vpffd::MeshData d = vpffd::read_mesh(p);
  fs::remove(p);
  EXPECT_TRUE(d.V == s.V);
  EXPECT_TRUE(d.F == s.F);
}
#else
TEST(MeshIO, OmWritingWithoutOpenMeshNamesThePackageAndWritesNothing) {
  const vpffd::TriMesh s = vpffd::icosphere(1);
  const std::string p = (fs::temp_directory_path() / "vpffd_test_refused.om").string();
  fs::remove(p);
  try {
    vpffd::write_mesh(p, s.V, s.F, vpffd::RowMatrixX3d(0, 3));
    ADD_FAILURE() << "no error";
  } catch (const vpffd::BackendUnavailableError& e) {
    EXPECT_NE(std::string(e.what()).find("libopenmesh-dev"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(p));
}
#endif

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

// A mesh whose coordinates use every bit of float64: an icosphere moved by random
// amounts, with a -0.0, a subnormal and values far outside float32's range.
vpffd::TriMesh awkward_mesh(bool float32_range) {
  vpffd::TriMesh m = vpffd::icosphere(2);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1e-3, 1e-3);
  for (vpffd::Index v = 0; v < m.V.rows(); ++v)
    for (int c = 0; c < 3; ++c) m.V(v, c) = m.V(v, c) * 3.141592653589793 + u(rng);
  m.V(0, 0) = -0.0;
  m.V(1, 1) = 0.1;
  if (!float32_range) {
    m.V(2, 2) = 4.9406564584124654e-324;
    m.V(3, 0) = 1.2345678901234567e300;
    m.V(4, 1) = -2.2250738585072014e-308;
  }
  return m;
}

std::string path_of(const std::string& name) { return (fs::temp_directory_path() / ("vpffd_test_" + name)).string(); }

vpffd::MeshData write_and_read(const std::string& name, const vpffd::RowMatrixX3d& V, const vpffd::RowMatrixX3i& F,
                               int binary, const vpffd::RowMatrixX3d& N = vpffd::RowMatrixX3d(0, 3),
                               vpffd::WriteReport* report = nullptr) {
  const std::string p = path_of(name);
  vpffd::WriteOptions opt;
  opt.binary = binary;
  const vpffd::WriteReport r = vpffd::write_mesh(p, V, F, N, opt);
  if (report) *report = r;
  vpffd::MeshData d = vpffd::read_mesh(p);
  fs::remove(p);
  return d;
}

bool same_bits(const vpffd::RowMatrixX3d& a, const vpffd::RowMatrixX3d& b) {
  return a.rows() == b.rows() && std::memcmp(a.data(), b.data(), sizeof(double) * static_cast<size_t>(a.size())) == 0;
}

vpffd::RowMatrixX3d to_float32(vpffd::RowMatrixX3d V) {
  for (vpffd::Index i = 0; i < V.size(); ++i) V.data()[i] = static_cast<float>(V.data()[i]);
  return V;
}

// OBJ, OFF and PLY store float64 exactly (ASCII with the default 17 digits, binary
// PLY as double), with normals; every bit comes back, -0.0 included.
TEST(MeshIO, ObjOffPlyRoundTripsAreExactInFloat64) {
  const vpffd::TriMesh m = awkward_mesh(false);
  vpffd::RowMatrixX3d N = m.V;
  N.rowwise().normalize();
  N(5, 0) = 0.30000000000000004;
  const struct { const char* name; int binary; } cases[] = {
      {"rt.obj", 0}, {"rt.off", 0}, {"rt_a.ply", 0}, {"rt_b.ply", 1}, {"rt_d.ply", -1}};
  for (const auto& c : cases)
    for (bool normals : {false, true}) {
      vpffd::WriteReport r;
      const vpffd::MeshData d =
          write_and_read(c.name, m.V, m.F, c.binary, normals ? N : vpffd::RowMatrixX3d(0, 3), &r);
      EXPECT_TRUE(same_bits(d.V, m.V)) << c.name;
      EXPECT_TRUE(d.F == m.F) << c.name;
      EXPECT_EQ(r.vertices_written, m.V.rows());
      EXPECT_EQ(r.split_faces, 0);
      EXPECT_EQ(r.dropped_faces, 0);
      if (normals)
        EXPECT_TRUE(same_bits(d.N, N)) << c.name;
      else
        EXPECT_EQ(d.N.rows(), 0) << c.name;
    }
}

// Binary OFF and binary STL store float32: what comes back is each coordinate
// rounded once to float32, exactly.
TEST(MeshIO, BinaryOffAndStlRoundTripsAreExactlyFloat32Rounded) {
  const vpffd::TriMesh m = awkward_mesh(true);
  const vpffd::MeshData off = write_and_read("rt_b.off", m.V, m.F, 1);
  EXPECT_TRUE(same_bits(off.V, to_float32(m.V)));
  EXPECT_TRUE(off.F == m.F);
  vpffd::WriteReport r;
  const vpffd::MeshData stl = write_and_read("rt_b.stl", m.V, m.F, -1, vpffd::RowMatrixX3d(0, 3), &r);
  EXPECT_EQ(r.vertices_written, 3 * m.F.rows());
  EXPECT_EQ(stl.V.rows(), m.V.rows());  // every position distinct: merged back to one vertex each
  ASSERT_EQ(stl.F.rows(), m.F.rows());
  const vpffd::RowMatrixX3d V32 = to_float32(m.V);
  for (vpffd::Index f = 0; f < m.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) ASSERT_TRUE(stl.V.row(stl.F(f, k)) == V32.row(m.F(f, k))) << f;
  // The first-seen order: vertex 0 is the first corner of the first facet, and so on.
  EXPECT_EQ(stl.F(0, 0), 0);
  EXPECT_EQ(stl.F(0, 1), 1);
  EXPECT_EQ(stl.F(0, 2), 2);
}

// ASCII STL keeps 17 digits: the positions come back as float64, exactly.
TEST(MeshIO, AsciiStlRoundTripIsExactInFloat64) {
  const vpffd::TriMesh m = awkward_mesh(false);
  const vpffd::MeshData d = write_and_read("rt_a.stl", m.V, m.F, 0);
  ASSERT_EQ(d.F.rows(), m.F.rows());
  EXPECT_EQ(d.V.rows(), m.V.rows());
  for (vpffd::Index f = 0; f < m.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) ASSERT_TRUE(d.V.row(d.F(f, k)) == m.V.row(m.F(f, k))) << f;
}

// Fewer digits round as printf's %g does.
TEST(MeshIO, PrecisionRoundsAsciiNumbers) {
  vpffd::RowMatrixX3d V(3, 3);
  V << 1.0 / 3, 0, 0, 1, 0, 0, 0, 1, 2.0 / 3;
  vpffd::RowMatrixX3i F(1, 3);
  F << 0, 1, 2;
  const std::string p = path_of("prec.obj");
  vpffd::WriteOptions opt;
  opt.precision = 3;
  vpffd::write_mesh(p, V, F, vpffd::RowMatrixX3d(0, 3), opt);
  std::ifstream in(p);
  std::stringstream text;
  text << in.rdbuf();
  fs::remove(p);
  EXPECT_NE(text.str().find("v 0.333 0 0\n"), std::string::npos) << text.str();
  EXPECT_NE(text.str().find("v 0 1 0.667\n"), std::string::npos) << text.str();
}

// No halfedge structure: a fin (three faces on one edge), a face with a repeated
// corner and a face of one vertex are written as given and read back unchanged.
TEST(MeshIO, NonManifoldFacesAndRepeatedCornersRoundTripUnchanged) {
  vpffd::RowMatrixX3d V(5, 3);
  V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1;
  vpffd::RowMatrixX3i F(5, 3);
  F << 0, 1, 2, 1, 0, 3, 0, 1, 4, 2, 2, 3, 4, 4, 4;
  for (const char* name : {"nm.obj", "nm.off", "nm_a.ply", "nm_b.ply"})
    for (int binary : {0, 1}) {
      if (std::string(name) == "nm.obj" && binary) continue;
      if (std::string(name).find("_a") != std::string::npos && binary) continue;
      vpffd::WriteReport r;
      const vpffd::MeshData d = write_and_read(name, V, F, binary, vpffd::RowMatrixX3d(0, 3), &r);
      EXPECT_TRUE(d.V == V) << name;
      EXPECT_TRUE(d.F == F) << name;
      EXPECT_EQ(r.split_faces, 0);
      EXPECT_EQ(r.dropped_faces, 0);
    }
  // STL keeps every facet too, its corners merged by position.
  const vpffd::MeshData stl = write_and_read("nm.stl", V, F, 1);
  EXPECT_TRUE(stl.F == F);
  EXPECT_TRUE(stl.V == V);
}

std::string f32(float v) {
  std::uint32_t u = 0;
  std::memcpy(&u, &v, 4);
  return u32(u);
}

std::string stl_record(const float (&p)[9]) {
  std::string r = f32(0) + f32(0) + f32(1);
  for (float x : p) r += f32(x);
  return r + std::string(2, '\0');
}

// Corners at exactly equal positions become one vertex (-0 and +0 are one
// position), numbered in the order they first appear.
TEST(MeshIO, StlMergesEqualPositionsInFirstSeenOrder) {
  const float a[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const float b[9] = {1, 0, 0, -0.0f, 0, 0, 0, 0, 1};
  const std::string header = "solid but binary: the size decides" + std::string(46, ' ');
  const std::string p = temp_file("merge.stl", header + u32(2) + stl_record(a) + stl_record(b));
  const vpffd::MeshData d = vpffd::read_mesh(p);
  fs::remove(p);
  ASSERT_EQ(d.V.rows(), 4);
  vpffd::RowMatrixX3d V(4, 3);
  V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  EXPECT_TRUE(d.V == V);
  vpffd::RowMatrixX3i F(2, 3);
  F << 0, 1, 2, 1, 0, 3;
  EXPECT_TRUE(d.F == F);
  EXPECT_EQ(d.polygons, 2);

  const std::string q = temp_file("merge_a.stl",
                                  "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
                                  "endloop\nendfacet\nfacet normal 0 0 1\nouter loop\nvertex 1 0 0\nvertex -0 0 0\n"
                                  "vertex 0 0 1\nendloop\nendfacet\nendsolid s\n");
  const vpffd::MeshData e = vpffd::read_mesh(q);
  fs::remove(q);
  EXPECT_TRUE(e.V == V);
  EXPECT_TRUE(e.F == F);
  EXPECT_TRUE(std::signbit(e.V(0, 0)) == false);  // the first-seen +0 stands for both
}

TEST(MeshIO, MalformedStlNamesTheProblem) {
  const float a[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const std::string head(80, ' ');
  const std::string rec = stl_record(a);
  const std::string tri = "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
                          "endloop\nendfacet\nendsolid t\n";
  auto with = [&](const std::string& from, const std::string& to) {
    std::string t = tri;
    t.replace(t.find(from), from.size(), to);
    return t;
  };
  const float nan[9] = {0, 0, 0, NAN, 0, 0, 0, 1, 0};
  const struct { std::string name, bytes, expect; } cases[] = {
      {"cut.stl", head + u32(2) + rec + rec.substr(0, 20), "truncated or not an STL file: the binary header announces 2 triangles (184 bytes), the file has 154 bytes"},
      {"count.stl", head + u32(1) + rec + rec, "announces 1 triangles (134 bytes), the file has 184 bytes"},
      {"short.stl", head.substr(0, 40), "truncated: a binary STL needs an 84-byte header"},
      {"nan.stl", head + u32(1) + stl_record(nan), "triangle 0 (byte 84) has a non-finite coordinate"},
      {"word.stl", with("vertex 1 0 0", "vertex 1 x 0"), "line 5: vertex: 'x' is not a number"},
      {"inf.stl", with("vertex 1 0 0", "vertex 1e400 0 0"), "line 5: vertex has a non-finite coordinate '1e400'"},
      {"arity.stl", with("vertex 1 0 0", "vertex 1 0"), "line 5: 'vertex' takes 3 values ('vertex x y z'), the line has 2"},
      {"arity4.stl", with("vertex 1 0 0", "vertex 1 0 0 0"), "line 5: 'vertex' takes 3 values"},
      {"normal.stl", with("facet normal 0 0 1", "facet normal 0 0"), "line 2: expected 'facet normal nx ny nz'"},
      {"loop.stl", with("outer loop", "outer"), "line 3: expected 'outer loop'"},
      {"four.stl", with("vertex 0 1 0\n", "vertex 0 1 0\nvertex 1 1 0\n"), "line 7: expected 'endloop'"},
      {"end.stl", tri.substr(0, tri.size() - 11), "the file is truncated: it ends where 'endsolid' was expected"},
      {"mid.stl", tri.substr(0, 38), "the file is truncated: it ends where 'vertex' was expected"},
      {"after.stl", tri + "vertex 0 0 0\n", "line 10: unexpected data after 'endsolid'"},
  };
  for (const auto& c : cases) {
    const std::string p = temp_file(c.name, c.bytes);
    const std::string e = error_of(p);
    fs::remove(p);
    EXPECT_NE(e.find(c.name), std::string::npos) << e;
    EXPECT_NE(e.find(c.expect), std::string::npos) << c.name << ": " << e;
  }
}

TEST(MeshIO, StlVariantsLoad) {
  // Upper-case keywords, blank lines, CRLF, names on solid and endsolid, two solids.
  const std::string text =
      "SOLID part one\r\n\r\n  FACET NORMAL 0 0 0\r\n OUTER LOOP\r\nVERTEX 0 0 0\r\nVERTEX 1 0 0\r\nVERTEX 0 1 0\r\n"
      "ENDLOOP\r\nENDFACET\r\nENDSOLID part one\r\nsolid two\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n"
      "vertex 0 1 0\nvertex 0 0 1\nendloop\nendfacet\nendsolid\n\n";
  const std::string p = temp_file("variants.stl", text);
  const vpffd::MeshData d = vpffd::read_mesh(p);
  fs::remove(p);
  EXPECT_EQ(d.V.rows(), 4);
  EXPECT_EQ(d.F.rows(), 2);
  EXPECT_EQ(d.F(1, 0), 0);
  EXPECT_EQ(d.F(1, 1), 2);
  EXPECT_EQ(d.F(1, 2), 3);
}

// Coordinates past float32's range cannot be stored in binary OFF or STL: refused
// before anything is written; ASCII and PLY (float64) take them.
TEST(MeshIO, BinaryFloat32FormatsRefuseHugeCoordinates) {
  vpffd::TriMesh m = vpffd::icosphere(1);
  m.V(3, 1) = 1e39;
  vpffd::WriteOptions bin;
  bin.binary = 1;
  for (const char* name : {"huge.stl", "huge.off"}) {
    const std::string p = path_of(name);
    fs::remove(p);
    EXPECT_THROW(vpffd::write_mesh(p, m.V, m.F, vpffd::RowMatrixX3d(0, 3), bin), vpffd::InvalidInputError);
    EXPECT_FALSE(fs::exists(p));
  }
  EXPECT_TRUE(same_bits(write_and_read("huge.ply", m.V, m.F, 1).V, m.V));
  EXPECT_EQ(write_and_read("huge_a.stl", m.V, m.F, 0).V.maxCoeff(), 1e39);
}

}  // namespace mesh_io_test
#endif
