#pragma once
/// @file foot_runs.h
/// The multiresolution frame of an FFD run one lattice cell at a time (the cell-run
/// kernels of ffd/cell_runs.h applied to the foot points).
///
/// At set-up the foot points are sorted by lattice cell (stably: caller order inside a
/// cell) and the frame data a vertex reads (S_u, S_v, d, the six coefficients) are
/// copied in that order, so a frame reads everything sequentially. Per run of foot
/// points in one cell, each coordinate of the control points becomes the cell's
/// polynomial once (to_power); then four points at a time get D and its gradient in
/// the local parameters by nested Horner (eval_power_grad), the gradient times
/// d tau / dx per axis is J_D, and the vertex is rebuilt (reconstruct_vertex) and
/// written to its caller row. Per point that is 3 (2 K^3 + 3 K^2 + 4 K) multiply-adds
/// over four lanes, against 3 K^2 for the basis and about 12 K^3 for the tensor sums
/// of the per-point kernel (ffd_value_jacobian).
///
/// Rounding: both evaluate the same power-form polynomials (the per-point kernel by
/// Horner on each axis's basis, then tensor sums), so they agree to a few units in the
/// last place of the largest term, not bit for bit; each point's arithmetic does not
/// depend on its lane or on where a thread's range starts, so the frame is the same
/// for any thread count. Uniform orders K = 2..6 only (dispatch_order); mixed orders
/// keep the per-point kernel.

#include <algorithm>
#include <numeric>

#include "vpffd/ffd/cell_runs.h"
#include "vpffd/multires/reconstruct.h"

namespace vpffd {

/// The foot points in cell order and the frame data in that order (SoA).
struct FootRuns {
  std::vector<std::int32_t> order;  ///< position v holds caller vertex order[v]
  Embedding embedding;              ///< the foot points' spans and local parameters, cell order
  CellRuns runs;
  std::array<std::vector<double>, 3> su, sv;
  std::vector<double> d;
  std::array<std::vector<double>, 6> coef;
  /// Bytes per vertex held: order (4), embedding (36), S_u, S_v, d, coefficients (128).
  static constexpr int bytes_per_vertex =
      int(sizeof(std::int32_t)) + int(Embedding::bytes_per_point) + 16 * int(sizeof(double));
};

/// Sorts the foot points of m (embedded in caller order as E, lattice tables T) by cell.
inline FootRuns foot_runs(const Multires& m, const BasisTables& T, const Embedding& E) {
  FootRuns F;
  const Index n = E.size();
  std::vector<std::int32_t> cell(n);
  for (Index i = 0; i < n; ++i) cell[i] = detail::cell_index(T, E, i);
  F.order.resize(n);
  std::iota(F.order.begin(), F.order.end(), 0);
  std::stable_sort(F.order.begin(), F.order.end(), [&](std::int32_t a, std::int32_t b) { return cell[a] < cell[b]; });
  auto gather = [&](const std::vector<double>& src, std::vector<double>& dst) {
    dst.resize(n);
    for (Index v = 0; v < n; ++v) dst[v] = src[F.order[v]];
  };
  for (int a = 0; a < 3; ++a) {
    F.embedding.span[a].resize(n);
    for (Index v = 0; v < n; ++v) F.embedding.span[a][v] = E.span[a][F.order[v]];
    gather(E.tau[a], F.embedding.tau[a]);
    gather(m.su[a], F.su[a]);
    gather(m.sv[a], F.sv[a]);
  }
  gather(m.d, F.d);
  for (int k = 0; k < 6; ++k) gather(m.coef[k], F.coef[k]);
  F.runs = cell_runs(F.embedding);
  return F;
}

namespace detail {

/// D and J_D (dD/dx) at the cell-ordered foot points [b, e), handed point after point
/// to sink(v, value, J) (v: cell-order position). P: control point coordinates (SoA);
/// du_dx: parameter_scale.
template <int K, class Sink>
void foot_runs_eval(const BasisTables& T, const FootRuns& F, const Vector3d& du_dx, const double* const P[3], Index b,
                    Index e, Sink&& sink) {
  const Index sj = T.dims[2], si = Index(T.dims[1]) * T.dims[2];
  PowerLanes<K> C[3];
  const Embedding& E = F.embedding;
  for_each_run(F.runs, b, e, [&](Index r, Index lo, Index hi) {
    const RunBasis rb = run_basis<K>(T, F.runs, r);
    for (int q = 0; q < 3; ++q) to_power<K>(rb, P[q], si, sj, C[q]);
    // d tau / dx per axis: the span's inverse width times the parameter scale, as the
    // per-point kernel scales the basis derivatives.
    double scale[3];
    for (int a = 0; a < 3; ++a) {
      const int s = F.runs.span[a][r];
      scale[a] = T.poly[a].inv_width[s - T.poly[a].first_span] * du_dx[a];
    }
    for (Index v = lo; v < hi; v += 4) {
      Lanes U, V, W;
      load_params(E, v, hi, U, V, W);
      Lanes f[3], g[3][3];
      for (int q = 0; q < 3; ++q) eval_power_grad<K>(C[q], U, V, W, f[q], g[q][0], g[q][1], g[q][2]);
      for (Index l = 0; l < 4 && v + l < hi; ++l) {
        Vector3d s1;
        Matrix3d J;
        for (int q = 0; q < 3; ++q) {
          s1[q] = f[q][l];
          for (int a = 0; a < 3; ++a) J(q, a) = g[q][a][l] * scale[a];
        }
        sink(v + l, s1, J);
      }
    }
  });
}

/// The frame for the cell-ordered points [b, e): vertex rows order[v] of X and N
/// (#V x 3, row-major). fix(caller row, value, J) may change the spline's value and
/// Jacobian before the vertex is rebuilt (a periodic lattice's seams: foot_seams.h).
template <int K, class Fix>
void reconstruct_runs(const BasisTables& T, const FootRuns& F, const Vector3d& du_dx, const double* const P[3],
                      double* X, double* N, Index b, Index e, Fix&& fix) {
  foot_runs_eval<K>(T, F, du_dx, P, b, e, [&](Index u, const Vector3d& value, const Matrix3d& JD) {
    Vector3d s1 = value;
    Matrix3d J = JD;
    fix(Index(F.order[u]), s1, J);
    const Vector3d su(F.su[0][u], F.su[1][u], F.su[2][u]), sv(F.sv[0][u], F.sv[1][u], F.sv[2][u]);
    NormalCoefficients c;
    for (int k = 0; k < 6; ++k) c[k] = F.coef[k][u];
    Vector3d p, nrm;
    reconstruct_vertex(s1, J * su, J * sv, F.d[u], c, p, nrm);
    const Index row = 3 * Index(F.order[u]);
    for (int a = 0; a < 3; ++a) {
      X[row + a] = p[a];
      N[row + a] = nrm[a];
    }
  });
}

}  // namespace detail
}  // namespace vpffd
