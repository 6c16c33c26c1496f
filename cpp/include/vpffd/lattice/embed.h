#pragma once
/// @file embed.h
/// Embedding points in a lattice: each point's knot span and local parameter per
/// axis, computed once per mesh and reused every frame.
///
/// Per point this is 3 spans (int32) and 3 local parameters (double): 36 bytes,
/// against the ~64 matrix weights per face (~1.5 kB per vertex) of the paper's
/// sparse-matrix formulation.

#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "vpffd/core/check.h"
#include "vpffd/core/parallel.h"
#include "vpffd/lattice/lattice.h"
#include "vpffd/lattice/periodic.h"

namespace vpffd {

/// What to do with points outside the lattice box.
enum class OutsidePolicy {
  Error,        ///< throw InvalidInputError naming the first such point (default)
  Extrapolate,  ///< continue the boundary polynomial pieces beyond the box; the
                ///< rest lattice still maps such points onto themselves
};

inline OutsidePolicy parse_outside_policy(const std::string& s) {
  if (s == "error") return OutsidePolicy::Error;
  if (s == "extrapolate") return OutsidePolicy::Extrapolate;
  throw InvalidInputError("outside: expected 'error' or 'extrapolate', got '" + s + "'");
}

/// Per-point basis data, structure of arrays.
struct Embedding {
  std::array<std::vector<std::int32_t>, 3> span;  ///< knot span index per axis
  std::array<std::vector<double>, 3> tau;         ///< local parameter in the span, [0, 1] inside
  Index size() const { return static_cast<Index>(span[0].size()); }
  static constexpr size_t bytes_per_point = 3 * (sizeof(std::int32_t) + sizeof(double));
};

/// The per-span power forms of the three axes, built once per lattice.
struct BasisTables {
  std::array<SpanPolynomials, 3> poly;
  std::array<int, 3> order{};  ///< degree + 1 per axis
  std::array<int, 3> dims{};
};

inline BasisTables basis_tables(const Lattice& L) {
  BasisTables T;
  for (int a = 0; a < 3; ++a) {
    T.poly[a] = span_polynomials(L.knots[a], L.dim(a), L.degree[a]);
    T.order[a] = L.degree[a] + 1;
    T.dims[a] = L.dim(a);
  }
  return T;
}

/// Embeds the rows of X (#X x 3 world points).
/// @param what  name used in error messages ("vertex", "point")
/// @throws InvalidInputError for non-finite points, or points outside the box
///         when `policy` is Error (the message names the first one and the count).
inline Embedding embed(const Lattice& L, const Eigen::Ref<const RowMatrixX3d>& X, OutsidePolicy policy,
                       int threads = 0, const char* what = "vertex") {
  const Index n = X.rows();
  Embedding E;
  for (int a = 0; a < 3; ++a) {
    E.span[a].resize(n);
    E.tau[a].resize(n);
  }
  // Rounding in the box computation must not throw out points on its faces.
  Vector3d tol;
  for (int a = 0; a < 3; ++a) tol[a] = 1e-12 * (L.box_max[a] - L.box_min[a]);
  const bool periodic = L.any_periodic();
  const int chunks = chunk_count(n);
  std::vector<Index> first_bad(chunks, -1), n_bad(chunks, 0), first_nan(chunks, -1);
  parallel_chunks(n, chunks, threads, [&](int c, Index b, Index e) {
    for (Index v = b; v < e; ++v) {
      // Periodic axes have no outside: the point is wrapped into the box.
      const Vector3d x = periodic ? wrap_point(L, X.row(v).transpose()) : Vector3d(X.row(v).transpose());
      if (!x.allFinite()) {
        if (first_nan[c] < 0) first_nan[c] = v;
        continue;
      }
      bool outside = false;
      for (int a = 0; a < 3; ++a)
        outside |= x[a] < L.box_min[a] - tol[a] || x[a] > L.box_max[a] + tol[a];
      if (outside) {
        if (first_bad[c] < 0) first_bad[c] = v;
        ++n_bad[c];
      }
      const Vector3d u = parameter_of(L, x);
      // Extrapolated polynomial pieces grow as distance^degree: a thousand box
      // extents away they are no deformation anyone wants, and further away they
      // overflow. Such points are refused with the non-finite ones.
      bool too_far = !u.allFinite();
      for (int a = 0; a < 3 && !too_far; ++a) {
        const double w = L.domain_hi(a) - L.domain_lo(a);
        too_far = u[a] < L.domain_lo(a) - 1e3 * w || u[a] > L.domain_hi(a) + 1e3 * w;
      }
      if (too_far) {
        if (first_nan[c] < 0) first_nan[c] = v;
        continue;
      }
      for (int a = 0; a < 3; ++a) {
        double ua = u[a];
        if (policy == OutsidePolicy::Error) ua = std::clamp(ua, L.domain_lo(a), L.domain_hi(a));
        const int s = find_span(L.knots[a], L.dim(a), L.degree[a], ua);
        E.span[a][v] = s;
        E.tau[a][v] = (ua - L.knots[a][s]) / (L.knots[a][s + 1] - L.knots[a][s]);
      }
    }
  });
  for (int c = 0; c < chunks; ++c)
    VPFFD_CHECK(first_nan[c] < 0, "embed: ", what, " ", first_nan[c],
                " is not finite, or too far from the lattice (over 1000 box extents)");
  if (policy == OutsidePolicy::Error) {
    Index total = 0, first = -1;
    for (int c = 0; c < chunks; ++c) {
      total += n_bad[c];
      if (first < 0 && first_bad[c] >= 0) first = first_bad[c];
    }
    if (total > 0) {
      const Vector3d x = X.row(first).transpose();
      const std::string noun = total == 1 ? std::string(what) + " lies"
                               : std::string(what) == "vertex" ? std::string("vertices lie")
                                                               : std::string(what) + "s lie";
      throw InvalidInputError(detail::concat(
          "embed: ", total, " ", noun, " outside the lattice box [", L.box_min.x(),
          ", ", L.box_max.x(), "] x [", L.box_min.y(), ", ", L.box_max.y(), "] x [", L.box_min.z(), ", ",
          L.box_max.z(), "], the first is ", what, " ", first, " at (", x.x(), ", ", x.y(), ", ", x.z(),
          "); enlarge the lattice (padding) or pass outside='extrapolate'"));
    }
  }
  return E;
}

}  // namespace vpffd
