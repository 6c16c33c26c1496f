#pragma once
/// @file rest_volume.h
/// The rest mesh's enclosed volume, summed on first use.
///
/// Moving the rest mesh (set_rest_vertices) changes it, but only a volume-preserving
/// frame aiming at the default target, and whoever asks for the rest volume, read it:
/// plain frames, frames with targets of their own and the moves themselves do not. Its
/// face pass was ~13 % of a CPU move (bench/results/vm/move_ab_vm.md) and about half of a
/// Vulkan move's host share (bench/results/vm/vulkan_move_host_vm.md), so both backends
/// sum it when first read (after a move: from the rest vertices they keep) and then
/// keep it. The same function, faces and threads as an eager sum: the same bits.
///
/// What an eager sum also did was refuse a rest mesh whose volume overflows double
/// precision, when it was set. That refusal stays where it was, by a bound: a vertex
/// the lattice takes lies within 1000 box extents of the box along every axis without
/// periodicity (lattice/embed.h), so with R the largest distance of such a point from
/// the box centre every term of the sum, (p0 - o) . ((p1 - o) x (p2 - o)), has
/// |term| <= |p0 - o| |p1 - o| |p2 - o| <= R^3, every product inside it <= R^3, and
/// F terms sum to at most F R^3 (times 1 + F u for the rounding, < 2). Where F R^3 is
/// finite and below 1e300 no sum can overflow, and the volume waits for its first use;
/// otherwise (huge boxes, or meshes far along a periodic axis) it is summed, and
/// checked, at once. Along a periodic axis a position may be any distance away (it is
/// wrapped into the box): there the reach is the vertices' own, one pass over that
/// coordinate (a fraction of a face pass, which reads three rows per face at random).

#include <algorithm>
#include <cmath>
#include <vector>

#include "vpffd/core/check.h"
#include "vpffd/core/parallel.h"
#include "vpffd/lattice/lattice.h"
#include "vpffd/mesh/volume.h"
#include "vpffd/volume/part_coefficients.h"

namespace vpffd {

/// A rest mesh's enclosed volume (the cone volume from the origin for an open one)
/// and, with parts, each part's.
struct RestVolumes {
  double total = 0;
  VectorXd parts;  ///< K with parts (their sum is `total`), else empty
};

/// Whether no F faces with vertices the lattice takes can have a sum of cone volumes
/// from the box centre past double range (see the file comment). V (vertices the
/// lattice took: finite) is read only along periodic axes.
inline bool rest_volume_stays_finite(const Lattice& L, Index n_faces, const Eigen::Ref<const RowMatrixX3d>& V,
                                     int threads = 0) {
  double r2 = 0;
  for (int a = 0; a < 3; ++a) {
    double reach = 1001.0 * (L.box_max[a] - L.box_min[a]);  // 1000 extents past the box, and half the box
    if (L.periodic(a)) {
      const double c = 0.5 * (L.box_min[a] + L.box_max[a]);
      const int chunks = chunk_count(V.rows());
      std::vector<double> far(chunks, 0.0);
      parallel_chunks(V.rows(), chunks, threads, [&](int k, Index b, Index e) {
        double m = 0;
        for (Index v = b; v < e; ++v) m = std::max(m, std::abs(V(v, a) - c));
        far[k] = m;
      });
      reach = 0;
      for (double m : far) reach = std::max(reach, m);
    }
    r2 += reach * reach;
  }
  const double r = std::sqrt(r2);
  const double bound = double(n_faces) * r * r * r;
  return std::isfinite(bound) && bound <= 1e300;
}

/// The volumes of rest vertices V: with `part_faces` (the faces grouped by part,
/// part k's rows [face_start[k], face_start[k+1])) each part's and their sum, else
/// signed_volume over F.
/// @throws InvalidInputError naming `where` when the volume overflows double precision
inline RestVolumes measure_rest_volumes(const Eigen::Ref<const RowMatrixX3d>& V, const RowMatrixX3i& F,
                                        const RowMatrixX3i* part_faces, const std::vector<Index>& face_start,
                                        const Vector3d& origin, int threads, const char* where) {
  RestVolumes r;
  if (part_faces) {
    r.parts = part_volumes(V, *part_faces, face_start, origin, threads);
    r.total = r.parts.sum();
  } else {
    r.total = signed_volume(V, F, origin, threads);
  }
  // Volumes grow with the cube of the mesh's size; past ~1e102 they leave double range,
  // and every volume a frame reports or aims at would be inf or NaN.
  VPFFD_CHECK(std::isfinite(r.total), where,
              ": the mesh's enclosed volume overflows double precision (it is beyond 1.8e308: coordinates up to ",
              V.cwiseAbs().maxCoeff(), "); scale the mesh to smaller units");
  return r;
}

}  // namespace vpffd
