#pragma once
/// @file cell_runs.h
/// The frame's per-point loops, one cell at a time, in the power form of the cell.
///
/// In processing order (vertex_order.h) the points of one lattice cell form a run.
/// Inside a cell a field given by control values D is one polynomial,
///   f(tau) = sum_{q,r,s} tau_u^q tau_v^r tau_w^s Dhat_qrs,
/// whose K^3 power coefficients Dhat are D times the three spans' coefficient
/// matrices (the same matrices point_basis evaluates by Horner). The change of
/// basis costs 3 K^4 multiply-adds once per run; afterwards a point needs no basis
/// values at all: the kernels evaluate f for four points at a time, one per SIMD
/// lane, by nested Horner (K^3 - 1 multiply-adds per four points, no horizontal
/// sums, many independent chains), where the per-point kernels spend 3 K^2 on the
/// basis and K^3 + K on a K-wide dot product whose reduction ends in a long chain.
/// The transpose (the coefficient scatter) accumulates a run's power moments
/// M_qrs = sum_v w_v tau_u^q tau_v^r tau_w^s and turns them into control values once.
///
/// Rounding: the per-point kernels form the same power-form polynomials (Horner on
/// the span coefficients), so both evaluate the same function with errors of a few
/// units in the last place of the largest term; the results agree to that level,
/// not bit for bit. A point's value does not depend on which lane or run piece
/// computes it (the tail of a piece runs the same code on padded lanes), so the
/// results are the same for any thread count.
///
/// Short runs: the change of basis costs as much as evaluating a few dozen points
/// point by point, so a run shorter than kShortRun (a coarse mesh in a fine
/// lattice: a few points per cell) takes the per-point kernels' arithmetic
/// instead. The choice depends on the whole run's length only, never on where a
/// chunk boundary splits it, so results stay the same for any thread count. The
/// basis values of a short run's points can be kept with the runs
/// (cache_short_run_basis): a frame's seven per-point passes then read them, and
/// evaluate nothing but the products with the control values.
///
/// Only for uniform orders K = 2..6 (dispatch_order); K = 0 keeps the per-point kernels.

#include <algorithm>
#include <array>
#include <vector>

#include "vpffd/ffd/kernels.h"

namespace vpffd {

/// Maximal runs of consecutive points (processing order) in one lattice cell.
struct CellRuns {
  std::vector<Index> start;                       ///< R + 1: run r is [start[r], start[r+1])
  std::array<std::vector<std::int32_t>, 3> span;  ///< R per axis: the run's knot spans
  /// Optional (cache_short_run_basis): the basis values of the points of short runs,
  /// 3K per point (the K values along u, then v, then w), run after run; run r's
  /// first point's at 3K * basis_start[r]. Empty: the kernels evaluate them.
  std::vector<Index> basis_start;  ///< R + 1 where `basis` is filled, else empty
  std::vector<double> basis;
  Index size() const { return static_cast<Index>(span[0].size()); }
  Index length(Index r) const { return start[r + 1] - start[r]; }
  size_t bytes() const {
    return start.size() * sizeof(Index) + 3 * span[0].size() * sizeof(std::int32_t) +
           basis_start.size() * sizeof(Index) + basis.size() * sizeof(double);
  }
};

/// Runs shorter than this take the per-point arithmetic (see the file comment).
inline constexpr Index kShortRun = 32;

/// The runs of E's points (in the order E holds them).
/// Chunks of points find their runs' starts in parallel; the runs are the same for
/// any thread count.
inline CellRuns cell_runs(const Embedding& E, int threads = 1) {
  const Index n = E.size();
  const int chunks = chunk_count(n);
  std::vector<std::vector<Index>> starts(chunks);
  parallel_chunks(n, chunks, threads, [&](int c, Index b, Index e) {
    const std::int32_t *s0 = E.span[0].data(), *s1 = E.span[1].data(), *s2 = E.span[2].data();
    for (Index v = b; v < e; ++v)
      if (v == 0 || s0[v] != s0[v - 1] || s1[v] != s1[v - 1] || s2[v] != s2[v - 1]) starts[c].push_back(v);
  });
  CellRuns R;
  Index total = 0;
  for (const auto& s : starts) total += static_cast<Index>(s.size());
  R.start.reserve(total + 1);
  for (const auto& s : starts) R.start.insert(R.start.end(), s.begin(), s.end());
  for (int a = 0; a < 3; ++a) {
    R.span[a].resize(total);
    for (Index r = 0; r < total; ++r) R.span[a][r] = E.span[a][R.start[r]];
  }
  R.start.push_back(n);
  return R;
}

/// Fills R.basis (see CellRuns): each point of a short run keeps its K basis values
/// per axis, which its run's per-point kernels read in every pass of every frame
/// instead of evaluating them (a frame's FFD, three scatters and three gathers each
/// spent about half their per-point time on the basis: 2,562-vertex sphere, 10^3
/// lattice). Long runs keep nothing (the power form needs no basis values), so this
/// costs 24 K bytes per point of a short run only (at most kShortRun - 1 per run). The values
/// are point_basis's own, so results are the same bits with or without them. Only
/// for uniform orders (the runs' kernels); otherwise R.basis is left empty.
inline void cache_short_run_basis(const BasisTables& T, const Embedding& E, CellRuns& R, int threads = 1) {
  R.basis_start.clear();
  R.basis.clear();
  detail::dispatch_order(T, [&](auto Kc) {
    constexpr int K = decltype(Kc)::value;
    if constexpr (K > 0) {
      const Index nr = R.size();
      R.basis_start.assign(nr + 1, 0);
      for (Index r = 0; r < nr; ++r)
        R.basis_start[r + 1] = R.basis_start[r] + (R.length(r) < kShortRun ? R.length(r) : 0);
      if (R.basis_start[nr] == 0) {
        R.basis_start.clear();
        return;
      }
      R.basis.resize(static_cast<size_t>(3 * K) * R.basis_start[nr]);
      parallel_range(nr, threads, [&](Index b, Index e) {
        for (Index r = b; r < e; ++r) {
          if (R.length(r) >= kShortRun) continue;
          double* out = R.basis.data() + 3 * K * R.basis_start[r];
          for (Index v = R.start[r]; v < R.start[r + 1]; ++v, out += 3 * K)
            detail::point_basis<K>(T, E, v, out, out + K, out + 2 * K);
        }
      });
    }
  });
}

namespace detail {

using Lanes = Eigen::Array<double, 4, 1>;

/// The basis values of point v of short run r, from R.basis where it is filled,
/// else evaluated into `own` (3 kMaxOrder): u, v and w values at K-strides.
template <int K>
VPFFD_ALWAYS_INLINE const double* short_run_basis(const BasisTables& T, const Embedding& E, const CellRuns& R,
                                                  Index r, Index v, double* own) {
  if (!R.basis.empty()) return R.basis.data() + 3 * K * (R.basis_start[r] + (v - R.start[r]));
  point_basis<K>(T, E, v, own, own + K, own + 2 * K);
  return own;
}

/// The run's coefficient matrices (c[q K + i]: power q of function i) and its
/// first control point.
struct RunBasis {
  const double* c[3];
  Index base;
};

template <int K>
VPFFD_ALWAYS_INLINE RunBasis run_basis(const BasisTables& T, const CellRuns& R, Index r) {
  RunBasis rb;
  Index first[3];
  for (int a = 0; a < 3; ++a) {
    const int s = R.span[a][r];
    rb.c[a] = T.poly[a].span_coef(s);
    first[a] = s - T.poly[a].degree;
  }
  rb.base = (first[0] * T.dims[1] + first[1]) * T.dims[2] + first[2];
  return rb;
}

/// Dhat[(q K + r) K + s] = sum_ijk cu[q][i] cv[r][j] cw[s][k] D[base + i si + j sj + k].
template <int K>
void to_power(const RunBasis& rb, const double* D, Index si, Index sj, double* Dhat) {
  double t1[K * K * K], t2[K * K * K];
  const double *cu = rb.c[0], *cv = rb.c[1], *cw = rb.c[2];
  for (int i = 0; i < K; ++i)
    for (int j = 0; j < K; ++j) {
      const double* d = D + rb.base + i * si + j * sj;
      for (int s = 0; s < K; ++s) {
        double x = 0;
        for (int k = 0; k < K; ++k) x += cw[s * K + k] * d[k];
        t1[(i * K + j) * K + s] = x;
      }
    }
  for (int i = 0; i < K; ++i)
    for (int r = 0; r < K; ++r)
      for (int s = 0; s < K; ++s) {
        double x = 0;
        for (int j = 0; j < K; ++j) x += cv[r * K + j] * t1[(i * K + j) * K + s];
        t2[(i * K + r) * K + s] = x;
      }
  for (int q = 0; q < K; ++q)
    for (int r = 0; r < K; ++r)
      for (int s = 0; s < K; ++s) {
        double x = 0;
        for (int i = 0; i < K; ++i) x += cu[q * K + i] * t2[(i * K + r) * K + s];
        Dhat[(q * K + r) * K + s] = x;
      }
}

/// acc[base + i si + j sj + k] += sum_qrs cu[q][i] cv[r][j] cw[s][k] M[(q K + r) K + s]:
/// a run's power moments M back to its control points (the transpose of to_power).
template <int K>
void add_from_power(const RunBasis& rb, const double* M, Index si, Index sj, double* acc) {
  double t1[K * K * K], t2[K * K * K];
  const double *cu = rb.c[0], *cv = rb.c[1], *cw = rb.c[2];
  for (int qr = 0; qr < K * K; ++qr)
    for (int k = 0; k < K; ++k) {
      double x = 0;
      for (int s = 0; s < K; ++s) x += cw[s * K + k] * M[qr * K + s];
      t1[qr * K + k] = x;
    }
  for (int q = 0; q < K; ++q)
    for (int j = 0; j < K; ++j)
      for (int k = 0; k < K; ++k) {
        double x = 0;
        for (int r = 0; r < K; ++r) x += cv[r * K + j] * t1[(q * K + r) * K + k];
        t2[(q * K + j) * K + k] = x;
      }
  for (int i = 0; i < K; ++i)
    for (int j = 0; j < K; ++j) {
      double* a = acc + rb.base + i * si + j * sj;
      for (int k = 0; k < K; ++k) {
        double x = 0;
        for (int q = 0; q < K; ++q) x += cu[q * K + i] * t2[(q * K + j) * K + k];
        a[k] += x;
      }
    }
}

/// A cell polynomial's K^3 power coefficients, each in all four lanes: the
/// evaluations' multiply-adds then read them as memory operands. (As scalars every
/// coefficient was first broadcast or shuffled into a register, and those shuffles
/// bound the loop: the FFD of the dragon's 435,545 vertices took 6.8 ms on one
/// thread instead of 4.6.)
template <int K>
using PowerLanes = std::array<Lanes, K * K * K>;

/// to_power into the four lanes of each coefficient.
template <int K>
void to_power(const RunBasis& rb, const double* D, Index si, Index sj, PowerLanes<K>& C) {
  alignas(32) double c[K * K * K];
  to_power<K>(rb, D, si, sj, c);
  for (int i = 0; i < K * K * K; ++i) C[i] = Lanes::Constant(c[i]);
}

/// The cell polynomial with power coefficients C at four points (nested Horner).
template <int K>
VPFFD_ALWAYS_INLINE Lanes eval_power(const PowerLanes<K>& C, const Lanes& U, const Lanes& V, const Lanes& W) {
  Lanes fu;
  for (int q = K - 1; q >= 0; --q) {
    Lanes fv;
    for (int r = K - 1; r >= 0; --r) {
      const Lanes* c = C.data() + (q * K + r) * K;
      Lanes fw = c[K - 1];
      for (int s = K - 2; s >= 0; --s) fw = fw * W + c[s];
      fv = r == K - 1 ? fw : Lanes(fv * V + fw);
    }
    fu = q == K - 1 ? fv : Lanes(fu * U + fv);
  }
  return fu;
}

/// The cell polynomial with power coefficients C and its gradient in the local
/// parameters (d/dtau_u, d/dtau_v, d/dtau_w) at four points: nested Horner that carries
/// the derivatives along (p' <- p' x + p before p <- p x + c at each level), so the
/// value is eval_power's and the three derivatives cost 2 K^3 + 3 K^2 + 4 K
/// multiply-adds in all, not three more polynomials of K^3 terms.
template <int K>
VPFFD_ALWAYS_INLINE void eval_power_grad(const PowerLanes<K>& C, const Lanes& U, const Lanes& V, const Lanes& W,
                                         Lanes& f, Lanes& fu, Lanes& fv, Lanes& fw) {
  for (int q = K - 1; q >= 0; --q) {
    Lanes g, gv, gw;
    for (int r = K - 1; r >= 0; --r) {
      const Lanes* c = C.data() + (q * K + r) * K;
      Lanes h = c[K - 1], hw = Lanes::Zero();
      for (int s = K - 2; s >= 0; --s) {
        hw = hw * W + h;
        h = h * W + c[s];
      }
      if (r == K - 1) {
        g = h;
        gv = Lanes::Zero();
        gw = hw;
      } else {
        gv = gv * V + g;
        g = g * V + h;
        gw = gw * V + hw;
      }
    }
    if (q == K - 1) {
      f = g;
      fu = Lanes::Zero();
      fv = gv;
      fw = gw;
    } else {
      fu = fu * U + f;
      f = f * U + g;
      fv = fv * U + gv;
      fw = fw * U + gw;
    }
  }
}

/// The local parameters of points [v, v + 4) clipped at `end`; lanes past it get 0
/// (evaluated and discarded: the same code for every point, whichever lane).
VPFFD_ALWAYS_INLINE void load_params(const Embedding& E, Index v, Index end, Lanes& U, Lanes& V, Lanes& W) {
  if (v + 4 <= end) {
    U = Eigen::Map<const Lanes>(E.tau[0].data() + v);
    V = Eigen::Map<const Lanes>(E.tau[1].data() + v);
    W = Eigen::Map<const Lanes>(E.tau[2].data() + v);
  } else {
    U = V = W = Lanes::Zero();
    for (Index l = 0; v + l < end; ++l) {
      U[l] = E.tau[0][v + l];
      V[l] = E.tau[1][v + l];
      W[l] = E.tau[2][v + l];
    }
  }
}

/// Calls f(run, lo, hi) for the pieces of the runs that cover [b, e), in order.
template <class F>
void for_each_run(const CellRuns& R, Index b, Index e, F&& f) {
  if (b >= e) return;
  Index r = static_cast<Index>(std::upper_bound(R.start.begin(), R.start.end(), b) - R.start.begin()) - 1;
  for (Index lo = b; lo < e; ++r) {
    const Index hi = std::min(e, R.start[r + 1]);
    f(r, lo, hi);
    lo = hi;
  }
}

/// The loop the gathers share: for the points of [b, e), run by run,
/// the NC fields with control values D[0..NC) at four points at a time; calls
/// f(v, n, g) with g[c] the field c at points [v, v + n), n <= 4 (lanes past n
/// hold padding).
template <int K, int NC, class F>
void eval_runs(const BasisTables& T, const Embedding& E, const CellRuns& R, const std::array<const double*, NC>& D,
               Index b, Index e, F&& f) {
  const Index sj = T.dims[2], si = Index(T.dims[1]) * T.dims[2];
  PowerLanes<K> C[NC];
  for_each_run(R, b, e, [&](Index r, Index lo, Index hi) {
    std::array<Lanes, NC> g;
    if (R.length(r) < kShortRun) {
      alignas(32) double own[3 * kMaxOrder];
      const Index base = cell_index(T, E, lo);
      for (Index v = lo; v < hi; ++v) {
        const double* B = short_run_basis<K>(T, E, R, r, v, own);
        for (int c = 0; c < NC; ++c) g[c][0] = basis_dot<K>(T, D[c], base, B, B + K, B + 2 * K, si, sj);
        f(v, 1, g);
      }
      return;
    }
    const RunBasis rb = run_basis<K>(T, R, r);
    for (int c = 0; c < NC; ++c) to_power<K>(rb, D[c], si, sj, C[c]);
    for (Index v = lo; v < hi; v += 4) {
      Lanes U, V, W;
      load_params(E, v, hi, U, V, W);
      for (int c = 0; c < NC; ++c) g[c] = eval_power<K>(C[c], U, V, W);
      f(v, std::min<Index>(4, hi - v), g);
    }
  });
}

/// out[v] = sum_ijk B_ijk(u_v) P_ijk for v in [b, e) (ffd_kernel, run by run; `rows`
/// and `skip` as there). eval_runs' loop written out for the three coordinates: with
/// the lanes kept in registers to the stores it runs ~5 % faster than through
/// eval_runs' callback.
template <int K>
void ffd_runs(const BasisTables& T, const Embedding& E, const CellRuns& R, const double* Px, const double* Py,
              const double* Pz, double* out, Index b, Index e, const std::int32_t* rows = nullptr, int skip = -1) {
  const Index sj = T.dims[2], si = Index(T.dims[1]) * T.dims[2];
  const double* P[3] = {Px, Py, Pz};
  PowerLanes<K> C[3];
  for_each_run(R, b, e, [&](Index r, Index lo, Index hi) {
    if (R.length(r) < kShortRun) {
      alignas(32) double own[3 * kMaxOrder];
      const Index base = cell_index(T, E, lo);
      for (Index v = lo; v < hi; ++v) {
        const double* B = short_run_basis<K>(T, E, R, r, v, own);
        double* o = out + 3 * (rows ? Index(rows[v]) : v);
        for (int c = 0; c < 3; ++c) o[c] = c == skip ? 0.0 : basis_dot<K>(T, P[c], base, B, B + K, B + 2 * K, si, sj);
      }
      return;
    }
    const RunBasis rb = run_basis<K>(T, R, r);
    for (int c = 0; c < 3; ++c)
      if (c != skip) to_power<K>(rb, P[c], si, sj, C[c]);
    for (Index v = lo; v < hi; v += 4) {
      Lanes U, V, W;
      load_params(E, v, hi, U, V, W);
      const Lanes x = skip == 0 ? Lanes::Zero() : eval_power<K>(C[0], U, V, W),
                  y = skip == 1 ? Lanes::Zero() : eval_power<K>(C[1], U, V, W),
                  z = skip == 2 ? Lanes::Zero() : eval_power<K>(C[2], U, V, W);
      for (Index l = 0; l < 4 && v + l < hi; ++l) {
        double* o = out + 3 * (rows ? Index(rows[v + l]) : v + l);
        o[0] = x[l];
        o[1] = y[l];
        o[2] = z[l];
      }
    }
  });
}

/// out[3 v + axis] += sum_c B_c(u_v) D[c] for v in [b, e) (gather_kernel, run by run).
template <int K>
void gather_runs(const BasisTables& T, const Embedding& E, const CellRuns& R, const double* D, double* out, int axis,
                 Index b, Index e) {
  eval_runs<K, 1>(T, E, R, {D}, b, e, [&](Index v, Index n, const std::array<Lanes, 1>& g) {
    for (Index l = 0; l < n; ++l) out[3 * (v + l) + axis] += g[0][l];
  });
}

/// gather_final_kernel run by run: moves point v by D along `axis` and returns
/// sum_v w[v] (x_v[axis] - o) over [b, e), added point after point in processing order.
template <int K>
double gather_final_runs(const BasisTables& T, const Embedding& E, const CellRuns& R, const double* D, double* X,
                         int axis, const double* w, double o, Index b, Index e) {
  double vsum = 0;
  eval_runs<K, 1>(T, E, R, {D}, b, e, [&](Index v, Index n, const std::array<Lanes, 1>& g) {
    for (Index l = 0; l < n; ++l) vsum += move_final(X, v + l, axis, g[0][l], w, o);
  });
  return vsum;
}

/// J[v] = dD/dx for the points of [b, e) (jacobian_points' layout, J holding points
/// j_first, j_first + 1, ...), run by run: the gradient of each coordinate's cell
/// polynomial in the local parameters (eval_power_grad) times the run's d tau / dx
/// per axis. The same function as jacobian_points, rounded differently.
template <int K>
void jacobian_runs(const BasisTables& T, const Embedding& E, const CellRuns& R, const double* Px, const double* Py,
                   const double* Pz, const Vector3d& du_dx, double* J, Index b, Index e, Index j_first = 0) {
  const Index sj = T.dims[2], si = Index(T.dims[1]) * T.dims[2];
  PowerLanes<K> C[3];
  const double* P[3] = {Px, Py, Pz};
  for_each_run(R, b, e, [&](Index r, Index lo, Index hi) {
    if (R.length(r) < kShortRun) {
      jacobian_points<K>(T, E, Px, Py, Pz, du_dx, J, lo, hi, j_first);
      return;
    }
    const RunBasis rb = run_basis<K>(T, R, r);
    double scale[3];
    for (int a = 0; a < 3; ++a) {
      const int s = R.span[a][r];
      scale[a] = T.poly[a].inv_width[s - T.poly[a].first_span] * du_dx[a];
    }
    for (int c = 0; c < 3; ++c) to_power<K>(rb, P[c], si, sj, C[c]);
    for (Index v = lo; v < hi; v += 4) {
      Lanes U, V, W;
      load_params(E, v, hi, U, V, W);
      Lanes f, g[3][3];
      for (int c = 0; c < 3; ++c) eval_power_grad<K>(C[c], U, V, W, f, g[c][0], g[c][1], g[c][2]);
      for (Index l = 0; l < 4 && v + l < hi; ++l) {
        double* out = J + 9 * (v + l - j_first);
        for (int c = 0; c < 3; ++c)
          for (int q = 0; q < 3; ++q) out[3 * c + q] = g[c][q][l] * scale[q];
      }
    }
  });
}

/// J[v] = dD/dx for v in [b, e) (jacobian_points' layout): run by run
/// (jacobian_runs) where the lattice's order is uniform, else point by point.
inline void jacobian_kernel(const BasisTables& T, const Embedding& E, const CellRuns& R, const double* Px,
                            const double* Py, const double* Pz, const Vector3d& du_dx, double* J, Index b, Index e,
                            Index j_first = 0) {
  dispatch_order(T, [&](auto Kc) {
    constexpr int k = decltype(Kc)::value;
    if constexpr (k > 0)
      jacobian_runs<k>(T, E, R, Px, Py, Pz, du_dx, J, b, e, j_first);
    else
      jacobian_points<k>(T, E, Px, Py, Pz, du_dx, J, b, e, j_first);
  });
}

/// Lane masks of scatter_runs' powers: kPowerMask<K>[q] lane l is 1 for l >= q,
/// else 0, and kPowerFill<K>[q] = 1 - kPowerMask<K>[q].
template <int K>
inline const std::array<Eigen::Array<double, K, 1>, K> kPowerMask = [] {
  std::array<Eigen::Array<double, K, 1>, K> m;
  for (int q = 0; q < K; ++q)
    for (int l = 0; l < K; ++l) m[q][l] = l >= q ? 1.0 : 0.0;
  return m;
}();
template <int K>
inline const std::array<Eigen::Array<double, K, 1>, K> kPowerFill = [] {
  std::array<Eigen::Array<double, K, 1>, K> m;
  for (int q = 0; q < K; ++q) m[q] = 1.0 - kPowerMask<K>[q];
  return m;
}();

/// acc[c] += weight(v) * B_c(u_v) for v in [b, e) (scatter_kernel, run by run):
/// weight(v) is called once per point, in order.
template <int K, class Weight>
void scatter_runs(const BasisTables& T, const Embedding& E, const CellRuns& R, Weight&& weight, double* acc, Index b,
                  Index e) {
  const Index sj = T.dims[2], si = Index(T.dims[1]) * T.dims[2];
  using KVec = Eigen::Array<double, K, 1>;
  alignas(32) double M[K * K * K];
  for_each_run(R, b, e, [&](Index r, Index lo, Index hi) {
    if (R.length(r) < kShortRun) {
      if (R.basis.empty()) {
        scatter_kernel<K>(T, E, weight, acc, lo, hi);
        return;
      }
      // scatter_kernel's arithmetic with the kept basis values: one cell, one block.
      KVec block[K * K];
      for (auto& x : block) x.setZero();
      const double* B = R.basis.data() + 3 * K * R.basis_start[r] + 3 * K * (lo - R.start[r]);
      for (Index v = lo; v < hi; ++v, B += 3 * K) {
        const double wv = weight(v);
        if (wv == 0.0) continue;
        scatter_point<K>(wv, B, B + K, B + 2 * K, block);
      }
      add_block<K>(block, acc + cell_index(T, E, lo), si, sj);
      return;
    }
    KVec m[K * K];
    for (auto& x : m) x.setZero();
    const double *tu = E.tau[0].data(), *tv = E.tau[1].data(), *tw = E.tau[2].data();
    // The weights of a block first, then its moments: weight() may be a loop of its
    // own (a vertex's fan) whose branches, in the same loop, stalled the moments'
    // multiply-adds (dragon, 1 thread: the xyz frame's coefficient passes 43 -> 36 ms).
    // Same values, same order of additions: the same bits as point after point.
    constexpr Index kBlock = 128;
    alignas(32) double wb[kBlock];
    for (Index v0 = lo; v0 < hi; v0 += kBlock) {
      const Index n = std::min(kBlock, hi - v0);
      for (Index i = 0; i < n; ++i) wb[i] = weight(v0 + i);
      for (Index v = v0; v < v0 + n; ++v) {
        // Powers of the local parameters: pu (times w), pv as scalars, pw as the
        // vector along s, built in registers: lane s is the product of the factors
        // (lane >= q ? tau : 1), q = 1..K-1, the same products as the scalar powers.
        // (Lanes written one by one and read as a vector stall on store forwarding.)
        double pu[K], pv[K];
        pu[0] = wb[v - v0];
        pv[0] = 1.0;
        for (int q = 1; q < K; ++q) {
          pu[q] = pu[q - 1] * tu[v];
          pv[q] = pv[q - 1] * tv[v];
        }
        const KVec t = KVec::Constant(tw[v]);
        KVec pw = KVec::Ones();
        for (int q = 1; q < K; ++q) pw *= kPowerMask<K>[q] * t + kPowerFill<K>[q];
        KVec vw[K];
        for (int j = 0; j < K; ++j) vw[j] = pv[j] * pw;
        for (int i = 0; i < K; ++i)
          for (int j = 0; j < K; ++j) m[i * K + j] += pu[i] * vw[j];
      }
    }
    for (int qr = 0; qr < K * K; ++qr) Eigen::Map<KVec>(M + qr * K) = m[qr];
    add_from_power<K>(run_basis<K>(T, R, r), M, si, sj, acc);
  });
}

}  // namespace detail
}  // namespace vpffd
