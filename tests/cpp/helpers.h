#pragma once
// Shared test fixtures: meshes generated in code and a few lattices.

#include <cmath>

#include <gtest/gtest.h>

#include "vpffd/vpffd.h"

namespace vpffd::test {

inline Lattice lattice_around(const RowMatrixX3d& V, std::array<int, 3> dims, int degree, double pad = 0.05) {
  const Vector3d lo = V.colwise().minCoeff().transpose(), hi = V.colwise().maxCoeff().transpose();
  const Vector3d ext = hi - lo;
  return make_lattice(lo - pad * ext, hi + pad * ext, dims, {degree, degree, degree});
}

/// Control points squashed along z to `f` of their height about the lattice centre.
inline RowMatrixX3d squashed(const Lattice& L, double f) {
  const Vector3d c = 0.5 * (L.box_min + L.box_max);
  return scale(rest_control_points(L), Vector3d(1, 1, f), c);
}

/// An icosphere with bumps (radius 1 + 0.05 sin 7x sin 7y sin 7z): details whose
/// displacement from a faired base is clearly non-zero.
inline TriMesh bumpy(int subdivisions) {
  TriMesh m = icosphere(subdivisions);
  for (Index i = 0; i < m.V.rows(); ++i) {
    const Vector3d u = m.V.row(i).normalized();
    m.V.row(i) = (u * (1.0 + 0.05 * std::sin(7 * u.x()) * std::sin(7 * u.y()) * std::sin(7 * u.z()))).transpose();
  }
  return m;
}

inline double rel(double a, double b) { return std::abs(a - b) / std::abs(b); }

}  // namespace vpffd::test
