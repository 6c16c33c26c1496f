#pragma once
/// @file certify.h
/// Fold-over certification of a B-spline lattice (000_4f6fff734e8a30e3.txt, §8):
/// prove det J > 0 over the whole domain, or find a point where det J < 0.
///
/// On a lattice cell (a box of non-empty knot spans) the FFD D is a polynomial
/// of degree (d_u, d_v, d_w). Bezier extraction gives its Bernstein net b; the
/// derivative along an axis is d_a times the forward differences of b (degree
/// one lower there), and det J = D_u . (D_v x D_w) is a polynomial of degree
/// 3 d_a - 1 per axis whose Bernstein coefficients are exact products of those
/// differences. det J lies in the convex hull of its coefficients, and the
/// corner coefficients are its values at the corners. So per (sub)cell:
///  - every coefficient > its rounding bound: det J > 0 on the closed cell (certified);
///  - a corner coefficient < -its rounding bound: det J < 0 at that corner (folded, witness);
///  - otherwise split the cell in eight by de Casteljau at 1/2 and test the
///    halves, down to `depth` levels; what is left is unknown.
/// The positive factors between the computed determinant and the world one
/// (d_a, the span widths, the box-to-parameter scale) never change a sign.
///
/// Rounding: the coefficients are computed in double. Next to the control net
/// the check carries an absolute net (the same operations on |coordinates|,
/// differences replaced by sums), whose maxima M_u, M_v, M_w over the three
/// difference nets bound the factors. In the scaled basis (bernstein.h) the
/// coefficient with multi-index k of D_u . (D_v x D_w) is a sum of six signed
/// triple products whose absolute sum is at most C(k) * 6 M_u M_v M_w, where
/// C(k) is the product of the binomials C(3 d_a - 1, k_a) (the unscaled weights sum
/// to one: Vandermonde). rounding.h turns that into the bound
///     thr(k) = 2 gamma_K * 6 M_u M_v M_w * C(k) + K * 1e-300,
/// and a coefficient decides only beyond it. A coefficient that is positive
/// but within rounding of zero therefore never certifies a cell.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <vector>

#include "vpffd/core/check.h"
#include "vpffd/core/parallel.h"
#include "vpffd/folds/bernstein.h"
#include "vpffd/folds/bezier_extraction.h"
#include "vpffd/folds/report.h"
#include "vpffd/folds/rounding.h"
#include "vpffd/lattice/lattice.h"

namespace vpffd {

/// Deepest subdivision check_folds accepts: 8^depth subcells per cell at most.
inline constexpr int kMaxFoldDepth = 10;
/// Subcells examined per cell at most, whatever the depth: keeps a degenerate
/// lattice (det J = 0 on a surface) from costing 8^depth products per cell.
inline constexpr int kMaxSubcellsPerCell = 4096;

namespace detail {

/// The FFD on one (sub)cell: Bernstein nets of x, y, z, their absolute nets,
/// the subdivision level and the subcell's integer origin at that level.
struct FoldNet {
  std::array<Bernstein3, 3> value, absolute;
  int level = 0;
  std::array<long, 3> origin{0, 0, 0};
};

/// Verdict on one (sub)cell.
struct SubcellVerdict {
  int sign = 0;                 ///< +1 certified, -1 folded, 0 undecided
  bool zero = false;            ///< every coefficient within rounding of zero
  double min_corner = 0;        ///< smallest corner value (unscaled, computed units)
  int min_corner_bits = 0;      ///< which corner: bit a set = far end along axis a
  double lower = 0;             ///< smallest coefficient minus its rounding bound
  double thr = 0;               ///< rounding bound of an unscaled coefficient
};

struct FoldWorkspace {
  Bernstein3 diff[3][3], diff_abs;  // diff[axis][coordinate]
  Bernstein3 cross[3], det;
  std::vector<FoldNet> stack;
  Bernstein3 half[2];
};

/// det J on one subcell: the test of the file comment.
inline SubcellVerdict test_subcell(const FoldNet& net, FoldWorkspace& w) {
  const std::array<int, 3> deg = net.value[0].degree;
  double M[3] = {0, 0, 0};
  for (int a = 0; a < 3; ++a)
    for (int c = 0; c < 3; ++c) {
      bernstein_difference(net.value[c], a, false, w.diff[a][c]);
      bernstein_difference(net.absolute[c], a, true, w.diff_abs);
      for (double x : w.diff_abs.c) M[a] = std::max(M[a], x);  // NaN-free: the input is finite
      bernstein_scale(w.diff[a][c]);
    }
  // Cross product D_v x D_w, degree (2 d_u, 2 d_v - 1, 2 d_w - 1).
  const auto& V = w.diff[1];
  const auto& W = w.diff[2];
  for (int c = 0; c < 3; ++c) {
    const int c1 = (c + 1) % 3, c2 = (c + 2) % 3;
    w.cross[c].reset({2 * deg[0], 2 * deg[1] - 1, 2 * deg[2] - 1});
    bernstein_product_add(V[c1], W[c2], 1.0, w.cross[c]);
    bernstein_product_add(V[c2], W[c1], -1.0, w.cross[c]);
  }
  const std::array<int, 3> N{3 * deg[0] - 1, 3 * deg[1] - 1, 3 * deg[2] - 1};
  w.det.reset(N);
  for (int c = 0; c < 3; ++c) bernstein_product_add(w.diff[0][c], w.cross[c], 1.0, w.det);

  const long K = det_rounding_steps(deg, net.level);
  const double thr = 2.0 * rounding_gamma(K) * 6.0 * M[0] * M[1] * M[2] + static_cast<double>(K) * kUnderflowSlack;
  SubcellVerdict out;
  out.thr = thr;
  if (!std::isfinite(thr)) return out;  // overflowing products decide nothing
  double bin[3][3 * kMaxDegree];
  for (int a = 0; a < 3; ++a)
    for (int i = 0; i <= N[a]; ++i) bin[a][i] = binomial(N[a], i);
  bool all_positive = true, all_zero = true, finite = true;
  double lower = std::numeric_limits<double>::infinity();
  for (int i = 0; i <= N[0]; ++i)
    for (int j = 0; j <= N[1]; ++j)
      for (int k = 0; k <= N[2]; ++k) {
        const double B = bin[0][i] * bin[1][j] * bin[2][k];
        const double c = w.det(i, j, k), t = thr * B;
        if (!std::isfinite(c)) {
          finite = false;
          continue;
        }
        all_positive = all_positive && c > t;
        all_zero = all_zero && std::abs(c) <= t;
        lower = std::min(lower, c / B - thr);
      }
  out.lower = finite ? lower : -std::numeric_limits<double>::infinity();
  out.min_corner = std::numeric_limits<double>::infinity();
  for (int bits = 0; bits < 8; ++bits) {
    const double c = w.det((bits & 1) ? N[0] : 0, (bits & 2) ? N[1] : 0, (bits & 4) ? N[2] : 0);
    if (std::isfinite(c) && c < out.min_corner) {
      out.min_corner = c;
      out.min_corner_bits = bits;
    }
  }
  if (finite && all_positive) out.sign = 1;
  else if (out.min_corner < -thr) out.sign = -1;
  out.zero = finite && all_zero;
  return out;
}

/// A witness inside the subcell near its negative corner `bits`, where det J is
/// still provably negative: a corner is shared with the neighbouring cells, and
/// where the FFD is only C^0 (degree 1, or knots of multiplicity d) det J jumps
/// there. Uses the det polynomial of the subcell just tested (w.det). Tries
/// points at 1/4, 1/8, .. 1/64 of the subcell from the corner and keeps the
/// first whose value is below -2 thr minus the evaluation's rounding, and at
/// least half as negative as the corner; else the corner itself (tau = -1).
inline double interior_witness(const SubcellVerdict& v, FoldWorkspace& w, std::array<double, 3>& tau) {
  Bernstein3 u = w.det;
  const auto& N = u.degree;
  double big = 0;
  for (int i = 0; i <= N[0]; ++i)
    for (int j = 0; j <= N[1]; ++j)
      for (int k = 0; k <= N[2]; ++k) {
        u(i, j, k) /= binomial(N[0], i) * binomial(N[1], j) * binomial(N[2], k);
        big = std::max(big, std::abs(u(i, j, k)));
      }
  const double margin = 2 * v.thr + rounding_gamma(4 * (N[0] + N[1] + N[2]) + 8) * big;
  for (double eps = 0.25; eps >= 1.0 / 64; eps *= 0.5) {
    for (int a = 0; a < 3; ++a) tau[a] = ((v.min_corner_bits >> a) & 1) ? 1 - eps : eps;
    const double val = bernstein_eval(u, tau[0], tau[1], tau[2]);
    if (val < -margin && val <= 0.5 * v.min_corner) return val;
  }
  for (int a = 0; a < 3; ++a) tau[a] = (v.min_corner_bits >> a) & 1;
  return v.min_corner;
}

/// Splits `net` into its eight children (octant order: bit a = upper half along axis a).
inline void split_net(const FoldNet& net, FoldWorkspace& w, FoldNet* children) {
  for (int q = 0; q < 8; ++q) {
    children[q].level = net.level + 1;
    for (int a = 0; a < 3; ++a) children[q].origin[a] = 2 * net.origin[a] + ((q >> a) & 1);
  }
  auto split_all = [&](auto member) {
    for (int c = 0; c < 3; ++c) {
      // Along axis 0 into children 0/1, then 1 into +2, then 2 into +4.
      bernstein_split_half((net.*member)[c], 0, (children[0].*member)[c], (children[1].*member)[c]);
      for (int h = 0; h < 2; ++h) {
        bernstein_split_half((children[h].*member)[c], 1, w.half[0], w.half[1]);
        (children[h].*member)[c] = w.half[0];
        (children[h + 2].*member)[c] = w.half[1];
      }
      for (int h = 0; h < 4; ++h) {
        bernstein_split_half((children[h].*member)[c], 2, w.half[0], w.half[1]);
        (children[h].*member)[c] = w.half[0];
        (children[h + 4].*member)[c] = w.half[1];
      }
    }
  };
  split_all(&FoldNet::value);
  split_all(&FoldNet::absolute);
}

/// Result for one lattice cell.
struct CellVerdict {
  CellStatus status = CellStatus::Unknown;
  double min_det = std::numeric_limits<double>::infinity();  // world units
  double lower = -std::numeric_limits<double>::infinity();   // world units
  int subcells = 0;
  bool has_witness = false;
  std::array<double, 3> witness_tau{0, 0, 0};  // position in the cell, [0, 1]^3
  double witness_det = 0;
};

/// Bernstein nets (value and absolute) of cell (su, sv, sw) of the lattice,
/// after translating its control points to their box centre and scaling them by
/// a power of two to magnitude <= 1 (both leave the sign of det J alone; the
/// power of two is returned in `sigma`).
inline void cell_net(const Lattice& L, const Eigen::Ref<const RowMatrixX3d>& P, const std::array<int, 3>& s,
                     const std::array<const double*, 3>& E, FoldNet& net, double& sigma) {
  const std::array<int, 3>& d = L.degree;
  const int n0 = d[0] + 1, n1 = d[1] + 1, n2 = d[2] + 1;
  const int i0 = s[0] - d[0], j0 = s[1] - d[1], k0 = s[2] - d[2];
  Vector3d lo = Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (int i = 0; i < n0; ++i)
    for (int j = 0; j < n1; ++j)
      for (int k = 0; k < n2; ++k) {
        const Vector3d p = P.row(L.index(i0 + i, j0 + j, k0 + k)).transpose();
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
      }
  const Vector3d centre = 0.5 * lo + 0.5 * hi;
  const double radius = (hi - centre).cwiseMax(centre - lo).maxCoeff();
  int e = 0;
  if (radius > 0 && std::isfinite(radius)) std::frexp(radius, &e);  // radius < 2^e
  sigma = std::ldexp(1.0, e);
  const double inv_sigma = std::ldexp(1.0, -e);
  std::vector<double> x(static_cast<size_t>(n0) * n1 * n2), t1(x.size()), t2(x.size());
  for (int c = 0; c < 3; ++c)
    for (int pass = 0; pass < 2; ++pass) {  // 0: values, 1: absolute values
      for (int i = 0; i < n0; ++i)
        for (int j = 0; j < n1; ++j)
          for (int k = 0; k < n2; ++k) {
            const double v = (P(L.index(i0 + i, j0 + j, k0 + k), c) - centre[c]) * inv_sigma;
            x[(static_cast<size_t>(i) * n1 + j) * n2 + k] = pass ? std::abs(v) : v;
          }
      // Contract with the extraction matrices along w, then v, then u.
      for (int i = 0; i < n0; ++i)
        for (int j = 0; j < n1; ++j)
          for (int r = 0; r < n2; ++r) {
            double acc = 0;
            for (int k = 0; k < n2; ++k) acc += E[2][r * n2 + k] * x[(static_cast<size_t>(i) * n1 + j) * n2 + k];
            t1[(static_cast<size_t>(i) * n1 + j) * n2 + r] = acc;
          }
      for (int i = 0; i < n0; ++i)
        for (int q = 0; q < n1; ++q)
          for (int r = 0; r < n2; ++r) {
            double acc = 0;
            for (int j = 0; j < n1; ++j) acc += E[1][q * n1 + j] * t1[(static_cast<size_t>(i) * n1 + j) * n2 + r];
            t2[(static_cast<size_t>(i) * n1 + q) * n2 + r] = acc;
          }
      Bernstein3& out = pass ? net.absolute[c] : net.value[c];
      out.reset(d);
      for (int p = 0; p < n0; ++p)
        for (int q = 0; q < n1; ++q)
          for (int r = 0; r < n2; ++r) {
            double acc = 0;
            for (int i = 0; i < n0; ++i) acc += E[0][p * n0 + i] * t2[(static_cast<size_t>(i) * n1 + q) * n2 + r];
            out(p, q, r) = acc;
          }
    }
  net.level = 0;
  net.origin = {0, 0, 0};
}

/// Certifies one cell, subdividing up to `depth` levels. `scale0` turns a
/// computed corner value of the whole cell into world det J; a level-l subcell
/// has 8^l times that scale (its derivatives are 2^l times shorter).
inline CellVerdict certify_cell(FoldNet root, int depth, double scale0, FoldWorkspace& w) {
  CellVerdict out;
  w.stack.clear();
  w.stack.push_back(std::move(root));
  bool all_certified = true;
  FoldNet children[8];
  while (!w.stack.empty()) {
    FoldNet net = std::move(w.stack.back());
    w.stack.pop_back();
    const SubcellVerdict v = test_subcell(net, w);
    ++out.subcells;
    const double scale = std::ldexp(scale0, 3 * net.level);
    if (std::isfinite(v.min_corner)) out.min_det = std::min(out.min_det, v.min_corner * scale);
    // The cell's bound is that of its whole net (the first one tested).
    if (net.level == 0) out.lower = v.lower * scale;
    if (v.sign < 0) {
      out.status = CellStatus::Folded;
      out.has_witness = true;
      std::array<double, 3> tau;
      out.witness_det = interior_witness(v, w, tau) * scale;
      for (int a = 0; a < 3; ++a)
        out.witness_tau[a] = std::ldexp(static_cast<double>(net.origin[a]) + tau[a], -net.level);
      return out;
    }
    if (v.sign > 0) continue;
    // Undecided: split unless the depth, the budget or a numerically zero det J says stop.
    if (net.level >= depth || v.zero || out.subcells + static_cast<int>(w.stack.size()) + 8 > kMaxSubcellsPerCell) {
      all_certified = false;
      continue;
    }
    split_net(net, w, children);
    for (int q = 7; q >= 0; --q) w.stack.push_back(std::move(children[q]));
  }
  out.status = all_certified ? CellStatus::Certified : CellStatus::Unknown;
  // A certified cell is positive everywhere: its bound is at least 0 (the
  // coarse coefficient bound may be lower; the subdivision proved more).
  if (all_certified) out.lower = std::max(out.lower, 0.0);
  return out;
}

}  // namespace detail

/// Checks the FFD of lattice L with control points P ((nu*nv*nw) x 3) for fold-over.
/// @param depth  subdivision levels for undecided cells, 0..kMaxFoldDepth (8^depth subcells at most)
/// @param threads  OpenMP threads (0: all); the report does not depend on it
/// @throws InvalidInputError for a bad lattice, a wrong shape, a non-finite coordinate or depth out of range
inline FoldReport check_folds(const Lattice& L, const Eigen::Ref<const RowMatrixX3d>& P, int depth = 3,
                              int threads = 0) {
  const auto t_start = std::chrono::steady_clock::now();
  validate_lattice(L);
  VPFFD_CHECK(P.rows() == L.n_control_points(), "check_folds: expected ", L.n_control_points(),
              " control points, got ", P.rows());
  VPFFD_CHECK(depth >= 0 && depth <= kMaxFoldDepth, "check_folds: depth ", depth, " not in [0, ", kMaxFoldDepth,
              "]");
  for (Index r = 0; r < P.rows(); ++r)
    VPFFD_CHECK(P.row(r).allFinite(), "check_folds: control point ", r, " is not finite");

  FoldReport rep;
  rep.depth = depth;
  std::array<std::vector<double>, 3> E;
  for (int a = 0; a < 3; ++a) {
    rep.spans[a] = nonempty_spans(L.knots[a], L.dim(a), L.degree[a]);
    rep.cells[a] = static_cast<int>(rep.spans[a].size());
    E[a] = bezier_extraction_all(L.knots[a], L.degree[a], rep.spans[a]);
  }
  const Index n_cells = Index(rep.cells[0]) * rep.cells[1] * rep.cells[2];
  rep.status.assign(n_cells, CellStatus::Unknown);
  rep.cell_min_det.assign(n_cells, 0.0);
  rep.cell_lower_bound.assign(n_cells, 0.0);
  rep.cell_subcells.assign(n_cells, 0);
  std::vector<detail::CellVerdict> verdicts(n_cells);
  const Vector3d ps = parameter_scale(L);

  auto run_cell = [&](Index cell, detail::FoldWorkspace& w) {
    const int ci = static_cast<int>(cell / (Index(rep.cells[1]) * rep.cells[2]));
    const int cj = static_cast<int>((cell / rep.cells[2]) % rep.cells[1]);
    const int ck = static_cast<int>(cell % rep.cells[2]);
    const std::array<int, 3> s{rep.spans[0][ci], rep.spans[1][cj], rep.spans[2][ck]};
    const std::array<int, 3> c{ci, cj, ck};
    std::array<const double*, 3> Ec;
    double scale0 = 1;
    for (int a = 0; a < 3; ++a) {
      const int K = L.degree[a] + 1;
      Ec[a] = E[a].data() + static_cast<size_t>(c[a]) * K * K;
      const double h = L.knots[a][s[a] + 1] - L.knots[a][s[a]];
      scale0 *= L.degree[a] * ps[a] / h;
    }
    detail::FoldNet net;
    double sigma = 1;
    detail::cell_net(L, P, s, Ec, net, sigma);
    verdicts[cell] = detail::certify_cell(std::move(net), depth, scale0 * sigma * sigma * sigma, w);
  };
  threads = resolve_threads(threads);
#ifdef _OPENMP
  if (threads > 1 && n_cells >= 16) {
#pragma omp parallel num_threads(threads)
    {
      detail::FoldWorkspace w;
#pragma omp for schedule(dynamic, 1)
      for (Index cell = 0; cell < n_cells; ++cell) run_cell(cell, w);
    }
  } else
#endif
  {
    detail::FoldWorkspace w;
    for (Index cell = 0; cell < n_cells; ++cell) run_cell(cell, w);
  }

  // Serial, in cell order: the report does not depend on the thread count.
  rep.min_det = std::numeric_limits<double>::infinity();
  rep.lower_bound = std::numeric_limits<double>::infinity();
  Index witness_cell = -1;
  for (Index cell = 0; cell < n_cells; ++cell) {
    const detail::CellVerdict& v = verdicts[cell];
    rep.status[cell] = v.status;
    rep.cell_min_det[cell] = v.min_det;
    rep.cell_lower_bound[cell] = v.lower;
    rep.cell_subcells[cell] = v.subcells;
    rep.n_subcells += v.subcells;
    rep.n_refined += v.subcells > 1;
    rep.n_certified += v.status == CellStatus::Certified;
    rep.n_folded += v.status == CellStatus::Folded;
    rep.n_unknown += v.status == CellStatus::Unknown;
    rep.min_det = std::min(rep.min_det, v.min_det);
    rep.lower_bound = std::min(rep.lower_bound, v.lower);
    if (v.has_witness && (witness_cell < 0 || v.witness_det < verdicts[witness_cell].witness_det)) witness_cell = cell;
  }
  rep.certified = n_cells > 0 && rep.n_certified == n_cells;
  rep.folded = rep.n_folded > 0;
  if (witness_cell >= 0) {
    const detail::CellVerdict& v = verdicts[witness_cell];
    const Index c[3] = {witness_cell / (Index(rep.cells[1]) * rep.cells[2]), (witness_cell / rep.cells[2]) % rep.cells[1],
                        witness_cell % rep.cells[2]};
    rep.has_witness = true;
    rep.witness_det = v.witness_det;
    for (int a = 0; a < 3; ++a) {
      rep.witness_cell[a] = static_cast<int>(c[a]);
      const int s = rep.spans[a][c[a]];
      const double t0 = L.knots[a][s], t1 = L.knots[a][s + 1];
      const double tau = v.witness_tau[a];
      const double u = tau >= 1 ? t1 : t0 + (t1 - t0) * tau;
      rep.witness_param[a] = u;
      const double lo = L.domain_lo(a), hi = L.domain_hi(a);
      rep.witness[a] = L.box_min[a] + (u - lo) / (hi - lo) * (L.box_max[a] - L.box_min[a]);
    }
  }
  rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return rep;
}

}  // namespace vpffd
