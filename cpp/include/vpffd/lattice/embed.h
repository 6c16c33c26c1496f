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

/// Embeds the rows of X (#X x 3 world points) into E (resized to #X; its buffers
/// are reused when they have that size already, as a moving mesh's do).
/// @param what   name used in error messages ("vertex", "point")
/// @param order  if not null, #X row indices: entry i of E embeds row order[i] (a
///               mesh embedded straight into its processing order)
/// @throws InvalidInputError for non-finite points, or points outside the box
///         when `policy` is Error (the message names the count and the one of
///         lowest row index, whatever `order`).
inline void embed_into(const Lattice& L, const Eigen::Ref<const RowMatrixX3d>& X, OutsidePolicy policy, Embedding& E,
                       int threads = 0, const char* what = "vertex", const std::int32_t* order = nullptr) {
  const Index n = X.rows();
  for (int a = 0; a < 3; ++a) {
    E.span[a].resize(n);
    E.tau[a].resize(n);
  }
  // Per-axis constants in locals: read through L inside the loop they would be
  // reloaded after every store (the stores could alias them, as far as the compiler knows).
  double in_lo[3], in_hi[3], dom_lo[3], dom_hi[3], far_lo[3], far_hi[3];
  for (int a = 0; a < 3; ++a) {
    // Rounding in the box computation must not throw out points on its faces.
    const double tol = 1e-12 * (L.box_max[a] - L.box_min[a]);
    in_lo[a] = L.box_min[a] - tol;
    in_hi[a] = L.box_max[a] + tol;
    dom_lo[a] = L.domain_lo(a);
    dom_hi[a] = L.domain_hi(a);
    // Extrapolated polynomial pieces grow as distance^degree: a thousand box
    // extents away they are no deformation anyone wants, and further away they
    // overflow. Such points are refused with the non-finite ones.
    far_lo[a] = dom_lo[a] - 1e3 * (dom_hi[a] - dom_lo[a]);
    far_hi[a] = dom_hi[a] + 1e3 * (dom_hi[a] - dom_lo[a]);
  }
  const SpanLocator locate[3] = {{L.knots[0], L.dim(0), L.degree[0]},
                                 {L.knots[1], L.dim(1), L.degree[1]},
                                 {L.knots[2], L.dim(2), L.degree[2]}};
  const ParameterMap to_parameter(L);
  const bool periodic = L.any_periodic(), clamp = policy == OutsidePolicy::Error;
  const int chunks = chunk_count(n);
  std::vector<Index> first_bad(chunks, -1), n_bad(chunks, 0), first_nan(chunks, -1);
  parallel_chunks(n, chunks, threads, [&](int c, Index b, Index e) {
    std::int32_t* __restrict span[3] = {E.span[0].data(), E.span[1].data(), E.span[2].data()};
    double* __restrict tau[3] = {E.tau[0].data(), E.tau[1].data(), E.tau[2].data()};
    // The lowest row index among this chunk's failures (the message names it).
    auto note = [](Index& first, Index row) { first = first < 0 ? row : std::min(first, row); };
    for (Index v = b; v < e; ++v) {
      const Index row = order ? Index(order[v]) : v;
      // Periodic axes have no outside: the point is wrapped into the box.
      const Vector3d x = periodic ? wrap_point(L, X.row(row).transpose()) : Vector3d(X.row(row).transpose());
      if (!x.allFinite()) {
        note(first_nan[c], row);
        continue;
      }
      // x is finite, so u is not NaN, and an infinite u is too far.
      const Vector3d u = to_parameter(x);
      bool outside = false, too_far = false;
      for (int a = 0; a < 3; ++a) {
        outside |= x[a] < in_lo[a] || x[a] > in_hi[a];
        too_far |= u[a] < far_lo[a] || u[a] > far_hi[a];
      }
      if (outside) {
        note(first_bad[c], row);
        ++n_bad[c];
      }
      if (too_far) {
        note(first_nan[c], row);
        continue;
      }
      for (int a = 0; a < 3; ++a) {
        const double ua = clamp ? std::clamp(u[a], dom_lo[a], dom_hi[a]) : u[a];
        const int s = locate[a](ua);
        span[a][v] = s;
        tau[a][v] = locate[a].local(ua, s);
      }
    }
  });
  // The lowest row index over the chunks (with `order` the chunks are not in row order).
  auto lowest = [&](const std::vector<Index>& per_chunk) {
    Index first = -1;
    for (Index f : per_chunk)
      if (f >= 0 && (first < 0 || f < first)) first = f;
    return first;
  };
  const Index bad_point = lowest(first_nan);
  VPFFD_CHECK(bad_point < 0, "embed: ", what, " ", bad_point,
              " is not finite, or too far from the lattice (over 1000 box extents)");
  if (policy == OutsidePolicy::Error) {
    Index total = 0;
    for (int c = 0; c < chunks; ++c) total += n_bad[c];
    const Index first = lowest(first_bad);
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
}

/// embed_into a new Embedding.
inline Embedding embed(const Lattice& L, const Eigen::Ref<const RowMatrixX3d>& X, OutsidePolicy policy,
                       int threads = 0, const char* what = "vertex") {
  Embedding E;
  embed_into(L, X, policy, E, threads, what);
  return E;
}

}  // namespace vpffd
