#pragma once
// Shared test fixtures: meshes generated in code and a few lattices.

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

inline double rel(double a, double b) { return std::abs(a - b) / std::abs(b); }

}  // namespace vpffd::test
