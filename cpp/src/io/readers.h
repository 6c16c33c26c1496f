#pragma once
// The per-format pieces behind read_mesh and write_mesh (internal; see the
// comment at the top of mesh_io.cpp for who reads and writes what).
//
// Every reader takes the file to read (`file`, perhaps a decompressed
// temporary), the name to show in messages (`shown`, see io_util.h) and the
// file's size, and throws MeshIOError naming the problem.
//
// Every writer but OM's formats the whole file into memory and returns its
// bytes (write_mesh puts them on the disk through replace_file); it writes every
// vertex and every face exactly as given, so it needs no halfedge structure and
// takes non-manifold meshes and faces with repeated corners. Arguments:
// V #V x 3 positions, F #F x 3 indices into V (checked by the caller), N #V x 3
// vertex normals or 0 rows, `precision` significant digits of ASCII numbers
// (see put_real in io_util.h).

#include <cstdint>
#include <string>
#include <vector>

#include "vpffd/io/mesh_io.h"

namespace vpffd::io_detail {

void read_obj(const std::string& file, const std::string& shown, MeshData& out);
/// ASCII OFF and OpenMesh's binary OFF ("OFF BINARY").
void read_off(const std::string& file, const std::string& shown, std::uint64_t size, MeshData& out);
void read_om(const std::string& file, const std::string& shown, std::uint64_t size, MeshData& out);
/// PLY, ASCII and binary, every type the format names (read_ply.cpp).
void read_ply(const std::string& file, const std::string& shown, std::uint64_t size, MeshData& out);
/// STL, ASCII and binary, equal positions merged into one vertex (read_stl.cpp).
void read_stl(const std::string& file, const std::string& shown, std::uint64_t size, MeshData& out);

using ConstV = Eigen::Ref<const RowMatrixX3d>;
using ConstF = Eigen::Ref<const RowMatrixX3i>;

/// OBJ: "v x y z", "vn nx ny nz" and "f a//a b//b c//c" with normals, "f a b c" without.
std::string format_obj(const ConstV& V, const ConstF& F, const ConstV& N, int precision);
/// OFF (NOFF with normals); binary: OpenMesh's little-endian layout with float32
/// coordinates and normals, which read_off reads back.
std::string format_off(const ConstV& V, const ConstF& F, const ConstV& N, bool binary, int precision);
/// PLY with float64 coordinates (and nx ny nz normals); binary is little-endian.
std::string format_ply(const ConstV& V, const ConstF& F, const ConstV& N, bool binary, int precision);
/// The body ASCII OFF and ASCII PLY share (write_off.cpp): one "x y z[ nx ny nz]" line
/// per vertex (normals when N has rows), then one "3 a b c" line per triangle.
void put_ascii_body(std::string& s, const ConstV& V, const ConstF& F, const ConstV& N, int precision);
/// STL with facet normals computed from the triangles (no vertex normals: the
/// format has none); binary STL stores float32 by definition.
std::string format_stl(const ConstV& V, const ConstF& F, bool binary, int precision);

/// OM through OpenMesh (openmesh_backend.cpp: its halfedge structure splits
/// non-manifold faces and drops faces with a repeated corner, which the report
/// counts), straight to `path` through replace_file. A build without OpenMesh
/// refuses it (openmesh_missing.cpp).
WriteReport write_om(const std::string& path, const std::string& shown, const ConstV& V, const ConstF& F,
                     const ConstV& N);

/// Fills out.F from triangles, out.V from 3 doubles per vertex, checking that
/// every index lies in [0, #V) (no reader's connectivity is trusted).
void finish_mesh(const std::string& shown, const std::vector<double>& V, const std::vector<int>& tris,
                 MeshData& out);

}  // namespace vpffd::io_detail
