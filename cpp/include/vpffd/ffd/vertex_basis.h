#pragma once
/// @file vertex_basis.h
/// The tensor-product basis of one embedded point, and dispatch on the spline order.
///
/// Kernels are templates on the order K = degree + 1 (the same on all three axes),
/// so the innermost loops have a compile-time length the compiler unrolls and
/// vectorises; K = 0 selects runtime orders (mixed degrees).

#include <type_traits>

#include "vpffd/core/dispatch.h"
#include "vpffd/lattice/embed.h"

namespace vpffd::detail {

inline constexpr int kMaxOrder = kMaxDegree + 1;

/// Basis values of point v along the three axes and the row of its first control point.
/// The cell of point v: the flat index of its first control point.
VPFFD_ALWAYS_INLINE std::int32_t cell_index(const BasisTables& T, const Embedding& E, Index v) {
  const Index i0 = E.span[0][v] - T.poly[0].degree, j0 = E.span[1][v] - T.poly[1].degree,
              k0 = E.span[2][v] - T.poly[2].degree;
  return static_cast<std::int32_t>((i0 * T.dims[1] + j0) * T.dims[2] + k0);
}

// The body of every hot loop: a call per point instead costs ~10% of a frame.
template <int K>
VPFFD_ALWAYS_INLINE Index point_basis(const BasisTables& T, const Embedding& E, Index v, double* bu, double* bv, double* bw) {
  const int s0 = E.span[0][v], s1 = E.span[1][v], s2 = E.span[2][v];
  if constexpr (K > 0) {
    eval_span<K>(T.poly[0].span_coef(s0), E.tau[0][v], bu);
    eval_span<K>(T.poly[1].span_coef(s1), E.tau[1][v], bv);
    eval_span<K>(T.poly[2].span_coef(s2), E.tau[2][v], bw);
  } else {
    eval_span(T.poly[0].span_coef(s0), T.order[0], E.tau[0][v], bu);
    eval_span(T.poly[1].span_coef(s1), T.order[1], E.tau[1][v], bv);
    eval_span(T.poly[2].span_coef(s2), T.order[2], E.tau[2][v], bw);
  }
  return cell_index(T, E, v);
}

/// Calls f(std::integral_constant<int, K>{}) with the uniform order, or K = 0.
template <class F>
decltype(auto) dispatch_order(const BasisTables& T, F&& f) {
  const int K = T.order[0];
  return with_constant<2, 6>(T.order[1] == K && T.order[2] == K ? K : 0, std::forward<F>(f));
}

}  // namespace vpffd::detail
