#pragma once
/// @file volume.h
/// Enclosed volume of a closed triangle mesh (eq. 7 of Hahmann et al. 2012), and
/// the face pass that the volume coefficients are built from.

#include <vector>

#include "vpffd/core/parallel.h"
#include "vpffd/core/types.h"

namespace vpffd {

namespace detail {
/// Six times the signed volume of the cone from o over the triangle (p0, p1, p2):
/// (p0 - o) . ((p1 - o) x (p2 - o)).
inline double cone6(const double* p0, const double* p1, const double* p2, const Vector3d& o) {
  const double a[3] = {p0[0] - o[0], p0[1] - o[1], p0[2] - o[2]};
  const double b[3] = {p1[0] - o[0], p1[1] - o[1], p1[2] - o[2]};
  const double c[3] = {p2[0] - o[0], p2[1] - o[1], p2[2] - o[2]};
  return a[0] * (b[1] * c[2] - b[2] * c[1]) + a[1] * (b[2] * c[0] - b[0] * c[2]) + a[2] * (b[0] * c[1] - b[1] * c[0]);
}
}  // namespace detail

/// Signed volume sum_f (p0 - o) . ((p1 - o) x (p2 - o)) / 6, positive for
/// outward-oriented closed meshes.
///
/// For a closed mesh the result does not depend on `origin`; a point near the
/// mesh (the default used by Deformer is the lattice centre) avoids cancellation
/// when the mesh lies far from the coordinate origin. For an open surface the value
/// is the volume of the cone from `origin` and depends on it.
/// @param[in] V  #V x 3 vertex positions (row-major, contiguous)
/// @param[in] F  #F x 3 vertex indices, assumed valid (see validate_mesh)
inline double signed_volume(const double* V, const Eigen::Ref<const RowMatrixX3i>& F,
                            const Vector3d& origin = Vector3d::Zero(), int threads = 0) {
  const Index nf = F.rows();
  const int chunks = chunk_count(nf);
  std::vector<double> part(chunks, 0.0);
  parallel_chunks(nf, chunks, threads, [&](int c, Index b, Index e) {
    double s = 0;
    for (Index f = b; f < e; ++f) {
      s += detail::cone6(V + 3 * Index(F(f, 0)), V + 3 * Index(F(f, 1)), V + 3 * Index(F(f, 2)), origin);
    }
    part[c] = s;
  });
  double s = 0;
  for (double p : part) s += p;
  return s / 6.0;
}

inline double signed_volume(const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F,
                            const Vector3d& origin = Vector3d::Zero(), int threads = 0) {
  // The pointer form reads rows three doubles apart; a strided view (three columns of
  // a wider array, which a Ref binds without copying) is copied first.
  if (V.rows() > 1 && V.outerStride() != 3) return signed_volume(RowMatrixX3d(V).data(), F, origin, threads);
  return signed_volume(V.data(), F, origin, threads);
}

/// Each face's cone volume from `origin`, (p0 - o) . ((p1 - o) x (p2 - o)) / 6: the
/// terms signed_volume sums (their sum is the mesh's volume, up to rounding).
/// @param[in] V  #V x 3 vertex positions; F assumed valid (see validate_mesh)
/// @returns #F volumes
inline VectorXd cone_volumes(const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F,
                             const Vector3d& origin, int threads = 0) {
  VectorXd out(F.rows());
  parallel_range(F.rows(), threads, [&](Index b, Index e) {
    auto row = [&](int c, Index f) { return V.data() + V.outerStride() * Index(F(f, c)); };  // rows are contiguous
    for (Index f = b; f < e; ++f) out[f] = detail::cone6(row(0, f), row(1, f), row(2, f), origin) / 6.0;
  });
  return out;
}

/// Component `axis` of each face's unnormalised normal (p1 - p0) x (p2 - p0):
/// the 2x2 determinants of eqs. 14, 16, 18. The volume is linear in the `axis`
/// coordinates with weight w_v = sum of n_f / 6 over the faces f around v.
inline void face_normal_component(const double* V, const Eigen::Ref<const RowMatrixX3i>& F, int axis, double* n,
                                  int threads = 0) {
  const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
  parallel_range(F.rows(), threads, [&](Index b, Index e) {
    for (Index f = b; f < e; ++f) {
      const double* p0 = V + 3 * Index(F(f, 0));
      const double* p1 = V + 3 * Index(F(f, 1));
      const double* p2 = V + 3 * Index(F(f, 2));
      n[f] = (p1[a1] - p0[a1]) * (p2[a2] - p0[a2]) - (p1[a2] - p0[a2]) * (p2[a1] - p0[a1]);
    }
  });
}

}  // namespace vpffd
