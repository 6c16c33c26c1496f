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
  const ParameterMap to_parameter(L);  // u = lo + (x - box_min) k, axis by axis
  double in_lo[3], in_hi[3], dom_lo[3], dom_hi[3], far_lo[3], far_hi[3], box_lo[3], scale[3];
  for (int a = 0; a < 3; ++a) {
    // Rounding in the box computation must not throw out points on its faces.
    const double tol = 1e-12 * (L.box_max[a] - L.box_min[a]);
    in_lo[a] = L.box_min[a] - tol;
    in_hi[a] = L.box_max[a] + tol;
    dom_lo[a] = to_parameter.lo[a];
    dom_hi[a] = L.domain_hi(a);
    // Extrapolated polynomial pieces grow as distance^degree: a thousand box
    // extents away they are no deformation anyone wants, and further away they
    // overflow. Such points are refused with the non-finite ones.
    far_lo[a] = dom_lo[a] - 1e3 * (dom_hi[a] - dom_lo[a]);
    far_hi[a] = dom_hi[a] + 1e3 * (dom_hi[a] - dom_lo[a]);
    box_lo[a] = to_parameter.box_min[a];
    scale[a] = to_parameter.k[a];
  }
  const SpanLocator locate[3] = {{L.knots[0], L.dim(0), L.degree[0]},
                                 {L.knots[1], L.dim(1), L.degree[1]},
                                 {L.knots[2], L.dim(2), L.degree[2]}};
  const bool periodic = L.any_periodic(), clamp = policy == OutsidePolicy::Error;
  // Points go in blocks: their coordinates copied (in processing order, wrapped on
  // periodic axes) into a buffer that stays in L1, then one axis at a time in a loop
  // with no data-dependent branch (SpanLocator::locate). A refused or outside point
  // is only noted there; the error path below looks for it again, in row order.
  constexpr Index kBlock = 512;
  const int chunks = chunk_count(n);
  std::vector<char> flagged(chunks, 0);  // bit 0: a point outside the box; bit 1: a refused point
  parallel_chunks(n, chunks, threads, [&](int c, Index b, Index e) {
    alignas(32) double buf[3 * kBlock];
    bool any_out = false, any_far = false;
    for (Index b0 = b; b0 < e; b0 += kBlock) {
      const Index m = std::min(kBlock, e - b0);
      for (Index i = 0; i < m; ++i) {
        const Index row = order ? Index(order[b0 + i]) : b0 + i;
        Vector3d x(X(row, 0), X(row, 1), X(row, 2));
        // Periodic axes have no outside: the point is wrapped into the box.
        if (periodic) x = wrap_point(L, x);
        for (int a = 0; a < 3; ++a) buf[a * kBlock + i] = x[a];
      }
      for (int a = 0; a < 3; ++a) {
        const SpanLocator& loc = locate[a];
        const double lo_in = in_lo[a], hi_in = in_hi[a], lo_dom = dom_lo[a], hi_dom = dom_hi[a],
                     lo_far = far_lo[a], hi_far = far_hi[a], lo_box = box_lo[a], k = scale[a];
        const double* __restrict xa = buf + a * kBlock;
        std::int32_t* __restrict span = E.span[a].data() + b0;
        double* __restrict tau = E.tau[a].data() + b0;
        bool out = false, far = false;
        for (Index i = 0; i < m; ++i) {
          out |= !(xa[i] >= lo_in && xa[i] <= hi_in);
          double u = lo_dom + (xa[i] - lo_box) * k;
          const bool ok = u >= lo_far && u <= hi_far;  // false for NaN
          far |= !ok;
          u = ok ? u : lo_dom;  // a refused point gets any finite value
          if (clamp) u = std::min(std::max(u, lo_dom), hi_dom);
          double t;
          span[i] = loc.locate(u, t);
          tau[i] = t;
        }
        any_out |= out;
        any_far |= far;
      }
    }
    flagged[c] = static_cast<char>((any_out ? 1 : 0) | (any_far ? 2 : 0));
  });
  char any = 0;
  for (char f : flagged) any |= f;
  if (!(any & 2) && !(clamp && (any & 1))) return;
  // The error path: the message names the lowest row index, whatever `order`.
  Index first_far = -1, first_out = -1, n_out = 0;
  for (Index row = 0; row < n && first_far < 0; ++row) {
    const Vector3d x = periodic ? wrap_point(L, X.row(row).transpose()) : Vector3d(X.row(row).transpose());
    bool outside = false, too_far = !x.allFinite();
    for (int a = 0; a < 3 && !too_far; ++a) {
      const double u = dom_lo[a] + (x[a] - box_lo[a]) * scale[a];
      outside |= x[a] < in_lo[a] || x[a] > in_hi[a];
      too_far |= u < far_lo[a] || u > far_hi[a];  // x is finite, so u is not NaN
    }
    if (too_far) first_far = row;
    if (outside && !too_far) {
      if (first_out < 0) first_out = row;
      ++n_out;
    }
  }
  VPFFD_CHECK(first_far < 0, "embed: ", what, " ", first_far,
              " is not finite, or too far from the lattice (over 1000 box extents)");
  if (clamp && n_out > 0) {
    const Vector3d x = X.row(first_out).transpose();
    const std::string noun = n_out == 1 ? std::string(what) + " lies"
                             : std::string(what) == "vertex" ? std::string("vertices lie")
                                                             : std::string(what) + "s lie";
    throw InvalidInputError(detail::concat(
        "embed: ", n_out, " ", noun, " outside the lattice box [", L.box_min.x(), ", ", L.box_max.x(), "] x [",
        L.box_min.y(), ", ", L.box_max.y(), "] x [", L.box_min.z(), ", ", L.box_max.z(), "], the first is ", what,
        " ", first_out, " at (", x.x(), ", ", x.y(), ", ", x.z(),
        "); enlarge the lattice (padding) or pass outside='extrapolate'"));
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
