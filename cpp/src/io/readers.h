#pragma once
// The per-format pieces behind read_mesh and write_mesh (internal; see the
// comment at the top of mesh_io.cpp for who reads what). Every reader takes
// the file to read (`file`, perhaps a decompressed temporary), the name to show
// in messages (`shown`, see io_util.h) and the file's size, and throws
// MeshIOError naming the problem.

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
/// STL checked completely before OpenMesh may read it: "" or the problem.
std::string check_stl(const std::string& file, const std::string& shown, std::uint64_t size);

/// STL through OpenMesh's reader (after check_stl).
void read_with_openmesh(const std::string& file, const std::string& shown, const std::string& ext, MeshData& out);
WriteReport write_with_openmesh(const std::string& path, const std::string& shown, const std::string& ext,
                                const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F,
                                const Eigen::Ref<const RowMatrixX3d>& N, const WriteOptions& options);

/// Fills out.F from triangles, out.V from 3 doubles per vertex, checking that
/// every index lies in [0, #V) (no reader's connectivity is trusted).
void finish_mesh(const std::string& shown, const std::vector<double>& V, const std::vector<int>& tris,
                 MeshData& out);

}  // namespace vpffd::io_detail
