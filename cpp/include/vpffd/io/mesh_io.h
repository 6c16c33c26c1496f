#pragma once
/// @file mesh_io.h
/// Triangle mesh files (target vpffd::io).
///
/// Formats: OBJ, OFF, PLY (ASCII and binary), STL (ASCII and binary), OM; any of
/// them gzip-compressed with a trailing ".gz" (read only). Polygons are
/// triangulated as fans. The faces come back exactly as stored in the file: no
/// vertex is merged or dropped and no face is discarded, even when the surface is
/// non-manifold, so that vpffd::check_mesh reports the defects of the file, not
/// of a repaired copy. (STL has no shared vertices; its reader merges corners at
/// exactly equal positions into one vertex, numbered in the order of first
/// appearance.) A face with a repeated corner ("f 1 1 1", "3 0 0 0") is kept as
/// stored, like any other; faces with fewer than 3 corners are counted in
/// MeshData::skipped_faces.
///
/// Every format is read by vpffd itself, and every format but OM is written by
/// it; writing OM needs OpenMesh (a build without it refuses only that, with
/// BackendUnavailableError). Every reader survives arbitrary bytes: counts are
/// checked against the file size before anything is allocated for them, face
/// indices against the vertex count, and a .gz may decompress to at most 1/16 of
/// the memory the process can still get. Anything that is not a finite number
/// where a coordinate belongs, a line with too few or too many values, or counts
/// that do not match the file is a MeshIOError naming the file (non-UTF-8 bytes
/// written as \xNN) and, for text, the line. cpp/src/io/mesh_io.cpp says which
/// part does what.
///
/// Precision of written files: ASCII OBJ, OFF, PLY and STL keep
/// WriteOptions::precision significant digits (the default, 17, reads back to
/// the very same float64 values); binary PLY and OM store float64 (exact);
/// binary OFF and binary STL store float32 (binary STL by the format's
/// definition; binary OFF in the layout OpenMesh reads and writes).
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
  /// and OFF); 0: ASCII (not for OM); 1: binary (not for OBJ).
  int binary = -1;
  /// significant digits of ASCII numbers, 1..17. 17 (the default) writes the
  /// shortest decimal text that reads back to exactly the same float64 (never
  /// more than 17 digits), so an ASCII round trip is exact; fewer digits round.
  /// Binary files ignore it (float64 for PLY and OM, float32 for OFF and STL).
  int precision = 17;
};

/// What write_mesh wrote, and what the format could not store as given.
struct WriteReport {
  /// Faces written with their own copies of their vertices: only OM, which stores
  /// OpenMesh's halfedge connectivity, splits non-manifold faces off this way.
  /// 0 for OBJ, OFF, PLY and STL, which store every face as given.
  Index split_faces = 0;
  /// Faces not written: only OM drops faces with a repeated vertex index (its
  /// halfedge structure has no such polygon). 0 for OBJ, OFF, PLY and STL.
  Index dropped_faces = 0;
  /// Vertex records in the file: #V for OBJ, OFF and PLY; #V plus the copies of
  /// split faces for OM; 3 per face for STL, which has no shared vertices (its
  /// reader merges equal positions, so vertices at one position become one, and
  /// vertices no face uses are not stored).
  Index vertices_written = 0;
};

/// Writes a triangle mesh.
/// @param[in] path  file name; the extension chooses the writer (.obj .off .ply .stl .om)
/// @param[in] V     #V x 3 vertex positions
/// @param[in] F     #F x 3 triangles
/// @param[in] N     #V x 3 vertex normals to store, or 0 rows for none (OBJ, OFF, PLY,
///                  OM; STL stores facet normals computed from each triangle instead)
/// @returns what was written (WriteReport)
/// @throws InvalidInputError for a bad mesh or options, or a coordinate beyond the
///         float32 range for binary OFF and STL; MeshIOError when the file cannot
///         be written (names the file and the reason; the old file is left as it
///         was and no temporary file remains); BackendUnavailableError for .om in a
///         build without OpenMesh
WriteReport write_mesh(const std::string& path, const Eigen::Ref<const RowMatrixX3d>& V,
                       const Eigen::Ref<const RowMatrixX3i>& F, const Eigen::Ref<const RowMatrixX3d>& N,
                       const WriteOptions& options = {});

/// Extensions read_mesh and write_mesh accept (without the dot and without ".gz").
std::vector<std::string> mesh_formats();

}  // namespace vpffd
