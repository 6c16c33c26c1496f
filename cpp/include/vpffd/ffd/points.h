#pragma once
/// @file points.h
/// The FFD of arbitrary points: what the Deformer does for its vertices, for points
/// that are embedded once and evaluated once (constraint sources, normals by mapped
/// tangents, lattice.deform_points).

#include "vpffd/core/check.h"
#include "vpffd/core/parallel.h"
#include "vpffd/ffd/kernels.h"
#include "vpffd/lattice/embed.h"
#include "vpffd/lattice/periodic.h"

namespace vpffd {

/// Plain FFD of arbitrary points (eq. 1).
/// @param[in] P  N x 3 control points of lattice L (the extended ones of a periodic lattice)
/// @param[in] X  #X x 3 rest-space points
/// @returns #X x 3 deformed points
/// @param[out] into  null, or the caller's #X x 3 row-major array to fill (then the
///                   returned matrix is empty)
inline RowMatrixX3d ffd_points(const Lattice& L, const Eigen::Ref<const RowMatrixX3d>& P,
                               const Eigen::Ref<const RowMatrixX3d>& X, OutsidePolicy policy = OutsidePolicy::Error,
                               int threads = 0, double* into = nullptr) {
  validate_lattice(L);
  VPFFD_CHECK(P.rows() == L.n_control_points(), "ffd_points: ", P.rows(), " control points, the lattice has ",
              L.n_control_points());
  VPFFD_CHECK(P.allFinite(), "ffd_points: control points contain NaN or Inf");
  const BasisTables T = basis_tables(L);
  const Embedding E = embed(L, X, policy, threads, "point");
  const PointColumns Q(P);
  RowMatrixX3d out(into ? 0 : X.rows(), 3);
  double* dst = into ? into : out.data();
  parallel_range(X.rows(), threads, [&](Index b, Index e) {
    detail::dispatch_order(T, [&](auto K) {
      detail::ffd_kernel<decltype(K)::value>(T, E, Q.x.data(), Q.y.data(), Q.z.data(), dst, b, e);
    });
  });
  const RowMatrixX3d shift = seam_translations(L, X);  // periodic "shift" seams: D(x + kL) = D(x) + kL
  if (shift.rows() > 0) Eigen::Map<RowMatrixX3d>(dst, X.rows(), 3) += shift;
  return out;
}

}  // namespace vpffd
