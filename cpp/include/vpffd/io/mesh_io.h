#pragma once
/// @file mesh_io.h
/// Triangle mesh files through OpenMesh's readers and writers (target vpffd::io).
///
/// Formats: OBJ, OFF, PLY (ASCII and binary), STL (ASCII and binary), OM; any of
/// them gzip-compressed with a trailing ".gz" (read only). Polygons are
/// triangulated as fans. The faces come back exactly as stored in the file: no
/// vertex is merged or dropped and no face is discarded, even when the surface is
/// non-manifold (OpenMesh's own mesh would split such faces off), so that
/// vpffd::check_mesh reports the defects of the file, not of a repaired copy.
/// (STL has no shared vertices; its reader merges equal positions.) A face with
/// a repeated corner ("f 1 1 1", "3 0 0 0") is kept as stored, like any other;
/// faces with fewer than 3 corners are counted in MeshData::skipped_faces.
///
/// OBJ, OFF (ASCII and binary), PLY (every type the format names) and OM are read
/// by vpffd itself; STL is checked through the whole file before OpenMesh reads it (OpenMesh's readers
/// turn "nan", "1 x 0" or a short file into vertices at 0 without an error, trust
/// header counts, and abort or loop on some corrupt headers). Every reader
/// survives arbitrary bytes: counts are checked against the file size before
/// anything is allocated for them, face indices against the vertex count, and a
/// .gz may decompress to at most 1/16 of the memory the process can still get.
/// Anything that is not a finite number where a coordinate belongs, a line with
/// too few or too many values, or counts that do not match the file is a
/// MeshIOError naming the file (non-UTF-8 bytes written as \xNN) and, for text,
/// the line. cpp/src/io/mesh_io.cpp says which part does what.
///
/// This header has no OpenMesh include: the implementation lives in cpp/src/io.

#include <string>
#include <vector>

#include "vpffd/core/types.h"

namespace vpffd {

/// What read_mesh found in a file.
struct MeshData {
  RowMatrixX3d V;                   ///< #V x 3 vertex positions (file units)
  RowMatrixX3i F;                   ///< #F x 3 triangles, indices into V
  RowMatrixX3d N;                   ///< #V x 3 vertex normals, or 0 rows when the file has none
  Index polygons = 0;               ///< faces in the file (before triangulation)
  Index triangulated_polygons = 0;  ///< faces with more than 3 corners, split into fans
  Index skipped_faces = 0;          ///< faces with fewer than 3 corners (ignored)
  std::string format;               ///< lower-case extension read, e.g. "ply"
  std::vector<std::string> notes;   ///< what the reader converted (e.g. integer coordinates read as float64)
  bool gzipped = false;             ///< the file was gzip-compressed
};

/// Reads a triangle mesh.
/// @param[in] path  file name as the OS's bytes (any bytes but NUL); its extension
///                  (.obj .off .ply .stl .om, optionally followed by .gz) chooses the reader
/// @returns vertices, triangles and, when present, vertex normals
/// @throws MeshIOError naming the file and the problem: missing, a directory,
///         empty, unknown extension, unreadable, truncated, no faces, face index
///         out of range, non-finite coordinates, a malformed line of an ASCII
///         file (with its line number), counts the file cannot hold, corrupt
///         OM connectivity, a .gz that decompresses beyond the bound, a NUL byte
///         in the name, not enough memory (never std::bad_alloc)
MeshData read_mesh(const std::string& path);

/// Options of write_mesh.
struct WriteOptions {
  /// -1: the format's usual encoding (binary for PLY, STL and OM; ASCII for OBJ
  /// and OFF); 0: ASCII; 1: binary (not for OBJ).
  int binary = -1;
  /// significant digits of ASCII coordinates. OpenMesh's OBJ, OFF, PLY and STL
  /// writers store float32 values (about 7 digits); only OM keeps float64.
  int precision = 17;
};

/// What write_mesh had to change to store the mesh in OpenMesh's halfedge structure.
struct WriteReport {
  Index split_faces = 0;    ///< non-manifold faces written with their own copies of their vertices
  Index dropped_faces = 0;  ///< faces with a repeated vertex index (no polygon; not written)
  Index vertices_written = 0;
};

/// Writes a triangle mesh.
/// @param[in] path  file name; the extension chooses the writer (.obj .off .ply .stl .om)
/// @param[in] V     #V x 3 vertex positions
/// @param[in] F     #F x 3 triangles
/// @param[in] N     #V x 3 vertex normals to store, or 0 rows for none (OBJ, OFF, PLY, OM)
/// @throws InvalidInputError for a bad mesh or options, MeshIOError when the file
///         cannot be written (names the file and the reason)
WriteReport write_mesh(const std::string& path, const Eigen::Ref<const RowMatrixX3d>& V,
                       const Eigen::Ref<const RowMatrixX3i>& F, const Eigen::Ref<const RowMatrixX3d>& N,
                       const WriteOptions& options = {});

/// Extensions read_mesh and write_mesh accept (without the dot and without ".gz").
std::vector<std::string> mesh_formats();

}  // namespace vpffd
