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
#include <limits>
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

/// The embedding's rules, each written once; the CPU embedding, the rest moves and
/// the Vulkan backend's checks all call these.
///
/// A point is inside the box along axis a when it lies within the box widened by
/// 1e-12 of the box's extent on each side: rounding in the box computation (a box
/// around a mesh, a mesh moved by whole extents) must not throw out points on its
/// faces.
struct AxisInterval {
  double lo, hi;
  bool contains(double x) const { return x >= lo && x <= hi; }
};
inline AxisInterval accepted_box(const Lattice& L, int a) {
  const double tol = 1e-12 * (L.box_max[a] - L.box_min[a]);
  return {L.box_min[a] - tol, L.box_max[a] + tol};
}
/// The parameters the embedding accepts along axis a, inside or outside the box:
/// the domain widened by 1000 domain widths on each side. Extrapolated polynomial
/// pieces grow as distance^degree: a thousand box extents away they are no
/// deformation anyone wants, and further away they overflow. Points beyond are
/// refused with the non-finite ones.
inline constexpr double kFarDomainWidths = 1e3;
inline AxisInterval accepted_parameters(const Lattice& L, int a) {
  const double w = L.domain_hi(a) - L.domain_lo(a);
  return {L.domain_lo(a) - kFarDomainWidths * w, L.domain_hi(a) + kFarDomainWidths * w};
}

namespace detail {

/// embed_into and embed_cells: the rows of X (in the order `order`, if not null)
/// embedded into E, or (E null) only their cells written to `cells`.
inline void embed_rows(const Lattice& L, const Eigen::Ref<const RowMatrixX3d>& X, OutsidePolicy policy, Embedding* E,
                       std::int32_t* cells, int threads, const char* what, const std::int32_t* order) {
  const Index n = X.rows();
  if (E)
    for (int a = 0; a < 3; ++a) {
      E->span[a].resize(n);
      E->tau[a].resize(n);
    }
  // Per-axis constants in locals: read through L inside the loop they would be
  // reloaded after every store (the stores could alias them, as far as the compiler knows).
  const ParameterMap to_parameter(L);  // u = lo + (x - box_min) k, axis by axis
  double in_lo[3], in_hi[3], dom_lo[3], dom_hi[3], far_lo[3], far_hi[3], box_lo[3], scale[3];
  for (int a = 0; a < 3; ++a) {
    const AxisInterval box = accepted_box(L, a), far = accepted_parameters(L, a);
    in_lo[a] = box.lo;
    in_hi[a] = box.hi;
    dom_lo[a] = to_parameter.lo[a];
    dom_hi[a] = L.domain_hi(a);
    far_lo[a] = far.lo;
    far_hi[a] = far.hi;
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
  constexpr Index kBlock = 512, kRowPrefetch = 16;
  const int chunks = chunk_count(n);
  std::vector<char> flagged(chunks, 0);  // bit 0: a point outside the box; bit 1: a refused point
  const Index cell_d[3] = {L.degree[0], L.degree[1], L.degree[2]}, cell_n[3] = {L.dim(0), L.dim(1), L.dim(2)};
  const double* xs = X.data();
  const Index stride = X.outerStride();
  parallel_chunks(n, chunks, threads, [&](int c, Index b, Index e) {
    alignas(32) double buf[3 * kBlock];
    // Without E, a block's spans and parameters go here (then its cells to `cells`).
    alignas(32) std::int32_t block_span[3 * kBlock];
    alignas(32) double block_tau[3 * kBlock];
    bool any_out = false, any_far = false;
    for (Index b0 = b; b0 < e; b0 += kBlock) {
      const Index m = std::min(kBlock, e - b0);
      // Everything the loops read is in locals: through the captured references the
      // compiler would reload it after every store, and no loop would vectorise.
      const std::int32_t* rows = order ? order + b0 : nullptr;
      for (Index i = 0; i < m; ++i) {
#if defined(__GNUC__)
        // Rows read in another order are read at random: asked for kRowPrefetch ahead.
        if (rows && b0 + i + kRowPrefetch < e) __builtin_prefetch(xs + stride * Index(rows[i + kRowPrefetch]));
#endif
        const double* p = xs + stride * (rows ? Index(rows[i]) : b0 + i);
        Vector3d x(p[0], p[1], p[2]);
        // Periodic axes have no outside: the point is wrapped into the box.
        if (periodic) x = wrap_point(L, x);
        buf[i] = x[0];
        buf[kBlock + i] = x[1];
        buf[2 * kBlock + i] = x[2];
      }
      for (int a = 0; a < 3; ++a) {
        const double lo_in = in_lo[a], hi_in = in_hi[a], lo_dom = dom_lo[a], hi_dom = dom_hi[a],
                     lo_far = far_lo[a], hi_far = far_hi[a], lo_box = box_lo[a], k = scale[a];
        double* __restrict xa = buf + a * kBlock;
        std::int32_t* __restrict span = E ? E->span[a].data() + b0 : block_span + a * kBlock;
        double* __restrict tau = E ? E->tau[a].data() + b0 : block_tau + a * kBlock;
        // Without clamping, infinite bounds make the clamp a no-op (u is finite there).
        const double c_lo = clamp ? lo_dom : -std::numeric_limits<double>::infinity(),
                     c_hi = clamp ? hi_dom : std::numeric_limits<double>::infinity();
        // The parameters u, in place of the coordinates, with the points outside or
        // refused noted. No branch (& and selects, not && and if; 64-bit flags, as wide
        // as the doubles), so that GCC vectorises the loop.
        std::int64_t out = 0, far = 0;
        for (Index i = 0; i < m; ++i) {
          const double x = xa[i];
          out |= std::int64_t(!(x >= lo_in)) | std::int64_t(!(x <= hi_in));
          const double u = lo_dom + (x - lo_box) * k;
          const std::int64_t ok = std::int64_t(u >= lo_far) & std::int64_t(u <= hi_far);  // 0 for NaN
          far |= ok ^ 1;
          double v = ok ? u : lo_dom;  // a refused point gets any finite value
          v = v < c_lo ? c_lo : v;     // std::max and std::min (the same values)
          xa[i] = c_hi < v ? c_hi : v;
        }
        const SpanLocator& loc = locate[a];
        if (loc.uniform()) {
          // SpanLocator::locate's uniform path on locals, the same numbers: f =
          // clamp(floor(g), 0, last). std::floor does not vectorise (GCC, with the default
          // trapping math); on h = clamp(g, 0, last + 1) a truncation is the floor, and
          // the clamps give f (floor is monotone, the bounds are integers). The clamp to
          // last is on the integer: on the double it kept GCC from vectorising.
          const double g_lo = loc.lo, steps = loc.steps_per_unit;
          const int d = loc.d, last = loc.n - 1 - loc.d;
          for (Index i = 0; i < m; ++i) {
            const double g = (xa[i] - g_lo) * steps;
            double h = g < 0.0 ? 0.0 : g;
            h = double(last) + 1.0 < h ? double(last) + 1.0 : h;
            int t = static_cast<int>(h);
            t = t > last ? last : t;
            tau[i] = g - double(t);
            span[i] = d + t;
          }
        } else {
          for (Index i = 0; i < m; ++i) {
            double t;
            span[i] = loc.locate(xa[i], t);
            tau[i] = t;
          }
        }
        any_out |= out != 0;
        any_far |= far != 0;
      }
      if (!E)  // the flat index of the cell's first control point (vertex_basis.h's cell_index)
        for (Index i = 0; i < m; ++i)
          cells[b0 + i] = static_cast<std::int32_t>(
              (Index(block_span[i] - cell_d[0]) * cell_n[1] + (block_span[kBlock + i] - cell_d[1])) * cell_n[2] +
              (block_span[2 * kBlock + i] - cell_d[2]));
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

}  // namespace detail

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
  detail::embed_rows(L, X, policy, &E, nullptr, threads, what, order);
}

/// The cell of each row of X as embed_into places it: the flat index of its first
/// control point ((i0 dim1 + j0) dim2 + k0), #X entries into `cells`. A processing
/// order sorted by these, the rows are then embedded straight into it (one pass
/// reading X, no permuted copy of the embedding's six arrays).
/// @throws InvalidInputError as embed_into
inline void embed_cells(const Lattice& L, const Eigen::Ref<const RowMatrixX3d>& X, OutsidePolicy policy,
                        std::vector<std::int32_t>& cells, int threads = 0, const char* what = "vertex") {
  cells.resize(X.rows());
  detail::embed_rows(L, X, policy, nullptr, cells.data(), threads, what, nullptr);
}

/// embed_into a new Embedding.
inline Embedding embed(const Lattice& L, const Eigen::Ref<const RowMatrixX3d>& X, OutsidePolicy policy,
                       int threads = 0, const char* what = "vertex") {
  Embedding E;
  embed_into(L, X, policy, E, threads, what);
  return E;
}

}  // namespace vpffd
