#pragma once
/// @file coefficients.h
/// The volume coefficients of one axis (alpha for x, beta for y, gamma for z;
/// eqs. 13-18): the volume is exactly V + alpha . delta when the control points
/// move by delta along that axis only, because the volume is linear in each
/// coordinate separately.

#include <algorithm>
#include <type_traits>
#include <vector>

#include "vpffd/core/dispatch.h"
#include "vpffd/core/parallel.h"
#include "vpffd/ffd/cell_runs.h"
#include "vpffd/ffd/kernels.h"
#include "vpffd/mesh/padded_fans.h"
#include "vpffd/mesh/validate.h"
#include "vpffd/sparse/spmv.h"
#include "vpffd/mesh/volume.h"

namespace vpffd {

/// Coefficients and the current volume, computed together.
struct AxisCoefficients {
  VectorXd alpha;  ///< N coefficients
  double volume = 0;
};

namespace detail {

/// alpha = sum of the chunk buffers (N each), added in chunk order.
inline VectorXd sum_chunks(const std::vector<double>& buf, int chunks, Index N, int threads) {
  VectorXd alpha(N);
  parallel_range(N, threads, [&](Index b, Index e) {
    for (Index r = b; r < e; ++r) {
      double s = 0;
      for (int c = 0; c < chunks; ++c) s += buf[static_cast<size_t>(c) * N + r];
      alpha[r] = s;
    }
  });
  return alpha;
}

/// Chunks of a vertex scatter: fixed by the vertex count (so results do not
/// depend on the thread count), and their N-double buffers capped at 64 MB.
inline int scatter_chunks(Index nv, Index N) {
  const int max_chunks = static_cast<int>(std::clamp<Index>((Index(64) << 20) / (8 * N), 1, 64));
  return chunk_count(nv, 8192, max_chunks);
}

/// acc[c] += weight(v) B_c(u_v) for v in [b, e): run by run in the power form
/// (cell_runs.h) when `runs` is given and the orders are uniform, else point by point.
template <class Weight>
void scatter(const BasisTables& T, const Embedding& E, const CellRuns* runs, Weight&& weight, double* acc, Index b,
             Index e) {
  dispatch_order(T, [&](auto K) {
    constexpr int k = decltype(K)::value;
    if constexpr (k > 0) {
      if (runs) {
        scatter_runs<k>(T, E, *runs, weight, acc, b, e);
        return;
      }
    }
    scatter_kernel<k>(T, E, weight, acc, b, e);
  });
}

/// A vertex's volume weight from its ring (coefficients_rings): (1/6) sum over its
/// faces (v, m, n) of ((p_m - b) x (p_n - b))_ax, b = (b1, b2) in the other two axes.
template <int ax>
inline double ring_weight(const double* X, const std::int32_t* ip, const std::int32_t* pr, Index v, double b1,
                          double b2) {
  constexpr int a1 = (ax + 1) % 3, a2 = (ax + 2) % 3;
  double w = 0;
  for (std::int32_t p = ip[v]; p < ip[v + 1]; ++p) {
    const double* pm = X + 3 * Index(pr[2 * p]);
    const double* pn = X + 3 * Index(pr[2 * p + 1]);
    w += (pm[a1] - b1) * (pn[a2] - b2) - (pm[a2] - b2) * (pn[a1] - b1);
  }
  return w * (1.0 / 6.0);
}

/// ring_weight for a closed mesh (b = p_v) from the vertex's fan (PaddedFans: its
/// row, a loop of fixed length, then the tail of a longer fan): each neighbour's two
/// coordinates read once, the terms in fan order. `r` is the fan's row (v where the
/// rows are in vertex order). W > 0: the rows' width as a compile-time constant (the
/// row loop unrolled, the same terms in the same order); W = 0: f.width.
template <int ax, int W = 0>
VPFFD_ALWAYS_INLINE double fan_weight(const double* X, const PaddedFans& f, Index v, Index r) {
  constexpr int a1 = (ax + 1) % 3, a2 = (ax + 2) % 3;
  const int width = W > 0 ? W : f.width;
  const std::int32_t* row = f.head.data() + r * width;
  const double b1 = X[3 * v + a1], b2 = X[3 * v + a2];
  const double* q = X + 3 * Index(row[0]);
  double u1 = q[a1] - b1, u2 = q[a2] - b2;
  double w = 0;
  auto term = [&](std::int32_t n) {
    q = X + 3 * Index(n);
    const double t1 = q[a1] - b1, t2 = q[a2] - b2;
    w += u1 * t2 - u2 * t1;
    u1 = t1;
    u2 = t2;
  };
  if constexpr (W > 0) {
#pragma GCC unroll 16
    for (int k = 1; k < W; ++k) term(row[k]);
  } else {
    for (int k = 1; k < width; ++k) term(row[k]);
  }
  for (std::int32_t p = f.tail_ptr[r]; p < f.tail_ptr[r + 1]; ++p) term(f.tail[p]);
  return w * (1.0 / 6.0);
}

template <int ax>
VPFFD_ALWAYS_INLINE double fan_weight(const double* X, const PaddedFans& f, Index v) {
  return fan_weight<ax>(X, f, v, v);
}

/// Calls f(std::integral_constant<int, W>{}) with W = width for the common row widths
/// (padded_fan_width: 5-8 on scanned and subdivided meshes), else W = 0.
template <class F>
decltype(auto) with_fan_width(int width, F&& f) {
  return with_constant<4, 8>(width, std::forward<F>(f));
}

/// Rows ahead whose neighbours fan_weights asks the cache for. A row's neighbours
/// lie in its cell's range of the positions, in an order no prefetcher follows, and
/// each fan's terms wait on their loads: asked for 16 rows ahead, a dragon's
/// (435,545 vertices) weight pass took 0.70-0.77 of the time it took without
/// (a microbenchmark of the pass, four runs), the coefficient passes of its frame
/// 0.84-0.92 (bench_frame, builds alternated). Positions that fit in a core's
/// second-level cache are found there anyway, and asking costs a 2,562-vertex
/// sphere's passes ~13 %: only meshes above kFanPrefetchBytes of positions ask.
inline constexpr Index kFanPrefetchRows = 16;
inline constexpr Index kFanPrefetchBytes = Index(256) << 10;

/// w[v] = fan_weight of every vertex, row by row: row r is the fan of vertex
/// row_vertex[r] (null: r). Rows stored by valence within each cell (the Deformer's
/// weight order) run loops of the same length one after the other.
template <int ax>
void fan_weights(const double* X, const PaddedFans& f, const std::int32_t* row_vertex, double* w, int threads) {
  with_fan_width(f.width, [&](auto width_c) {
    constexpr int W = decltype(width_c)::value;
    const int width = W > 0 ? W : f.width;
    const Index n = f.size();
    const bool ask = n * Index(3 * sizeof(double)) > kFanPrefetchBytes;
    parallel_range(n, threads, [&](Index b, Index e) {
      if (ask) {
        for (Index r = b; r < e; ++r) {
          if (r + kFanPrefetchRows < e) {
            const std::int32_t* ahead = f.head.data() + (r + kFanPrefetchRows) * width;
            for (int k = 0; k < width; ++k) prefetch(X + 3 * Index(ahead[k]));
          }
          const Index v = row_vertex ? Index(row_vertex[r]) : r;
          w[v] = fan_weight<ax, W>(X, f, v, r);
        }
      } else if (row_vertex) {
        for (Index r = b; r < e; ++r) w[row_vertex[r]] = fan_weight<ax, W>(X, f, row_vertex[r], r);
      } else {
        for (Index r = b; r < e; ++r) w[r] = fan_weight<ax, W>(X, f, r, r);
      }
    });
  });
}

/// Calls f(std::integral_constant<int, axis>{}): the axis as a compile-time
/// constant, so coordinate reads in the weight loops are loads at fixed offsets.
template <class F>
decltype(auto) with_axis(int axis, F&& f) {
  if (axis == 0) return f(std::integral_constant<int, 0>{});
  if (axis == 1) return f(std::integral_constant<int, 1>{});
  return f(std::integral_constant<int, 2>{});
}

/// The vertex pass every coefficient method shares: w_v = weight_of(v), then
/// alpha_c = sum_v w_v B_c(u_v) and volume = sum_v (x_v - o)_ax w_v. Vertices go
/// in fixed chunks, each with its own N-double buffer, summed in chunk order: no
/// atomics, the same result for any thread count.
/// @param[out] weights  if not null, #V: the w_v
/// @param measure  false: the volume is not summed (left 0), and the `ax` coordinates
///                 are not read: a caller that has the volume otherwise (a frame's
///                 alpha . (P - o), frame/deformer.h) saves that stream of X
template <int ax, class WeightOf>
AxisCoefficients weighted_scatter(const BasisTables& T, const Embedding& E, const CellRuns* runs, const double* X,
                                  double o, int threads, double* weights, WeightOf&& weight_of, bool measure = true) {
  const Index nv = E.size();
  const Index N = Index(T.dims[0]) * T.dims[1] * T.dims[2];
  const int chunks = scatter_chunks(nv, N);
  std::vector<double> buf(static_cast<size_t>(chunks) * N, 0.0);
  std::vector<double> vol(chunks, 0.0);
  // `measure` as a compile-time constant: tested per point, the branch slowed the
  // dragon's coefficient passes by ~4 % (bench_frame, two alternations).
  auto pass = [&](auto measure_c) {
    parallel_chunks(nv, chunks, threads, [&](int c, Index b, Index e) {
      double vsum = 0;
      auto weight = [&](Index v) {
        const double w = weight_of(v);
        if (weights) weights[v] = w;
        if constexpr (decltype(measure_c)::value) vsum += (X[3 * v + ax] - o) * w;
        return w;
      };
      scatter(T, E, runs, weight, buf.data() + static_cast<size_t>(c) * N, b, e);
      vol[c] = vsum;
    });
  };
  if (measure)
    pass(std::true_type{});
  else
    pass(std::false_type{});
  AxisCoefficients out;
  out.alpha = sum_chunks(buf, chunks, N, threads);
  for (double v : vol) out.volume += v;
  return out;
}

}  // namespace detail

/// O(F + N) single traversal (Section 7): each face's normal component n_f is
/// computed once; each vertex sums n_f / 6 over its faces (its weight w_v, the
/// derivative of the volume by its coordinate) and scatters w_v B_c(u_v) into the
/// control points that influence it. The scatter goes into one buffer per chunk
/// of vertices, summed in chunk order: no atomics, same result for any thread count.
/// @param X       #V x 3 current vertices (row-major)
/// @param origin  reference point for the volume (see signed_volume)
///
/// With `cone` the weights are the exact gradient of the cone volume from
/// `origin` (signed_volume), w_v = sum over faces (l, m, n) of
/// ((x_m - o) x (x_n - o))_axis / 6 with v = l: one value per face corner.
/// For a closed mesh both forms give the same volume and coefficients; for an
/// open one only the cone form matches signed_volume, so allow_open uses it.
inline AxisCoefficients coefficients_traversal(const BasisTables& T, const Embedding& E, const VertexFaces& vf,
                                               const double* X, const Eigen::Ref<const RowMatrixX3i>& F, int axis,
                                               const Vector3d& origin, int threads = 0, bool cone = false) {
  std::vector<double> nf(F.rows() * (cone ? 3 : 1));
  if (cone) {
    const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
    parallel_range(F.rows(), threads, [&](Index b, Index e) {
      for (Index f = b; f < e; ++f)
        for (int c = 0; c < 3; ++c) {
          const double* pm = X + 3 * Index(F(f, (c + 1) % 3));
          const double* pn = X + 3 * Index(F(f, (c + 2) % 3));
          nf[3 * f + c] = (pm[a1] - origin[a1]) * (pn[a2] - origin[a2]) - (pm[a2] - origin[a2]) * (pn[a1] - origin[a1]);
        }
    });
  } else {
    face_normal_component(X, F, axis, nf.data(), threads);
  }
  const std::int32_t* ip = vf.indptr.data();
  const std::int32_t* fa = vf.faces.data();
  auto weight_of = [&](Index v) {
    double w = 0;
    if (cone) {
      // A face that names v at two corners (a degenerate face, allowed on open
      // meshes) is listed twice in a row for v: each entry takes the next such corner,
      // so the two corner weights cancel as they must (the face's cone has no volume).
      int c = -1;
      for (std::int32_t p = ip[v]; p < ip[v + 1]; ++p) {
        const Index f = fa[p];
        c = (p > ip[v] && fa[p - 1] == f) ? c + 1 : 0;
        while (F(f, c) != v) ++c;
        w += nf[3 * f + c];
      }
    } else {
      for (std::int32_t p = ip[v]; p < ip[v + 1]; ++p) w += nf[fa[p]];
    }
    return w * (1.0 / 6.0);
  };
  return detail::with_axis(axis, [&](auto axis_c) {
    return detail::weighted_scatter<decltype(axis_c)::value>(T, E, nullptr, X, origin[axis], threads, nullptr,
                                                             weight_of);
  });
}


/// The frame's coefficient pass: coefficients_traversal's result in one pass over
/// the vertices. Each vertex computes its own weight from its ring (vertex_rings),
/// w_v = (1/6) sum over its faces (v, m, n) of ((p_m - b) x (p_n - b))_axis, with
/// b = p_v for a closed mesh (the face's normal component, exactly as the face
/// pass computes it but from another corner) and b = origin for the cone form;
/// then scatters w_v B_c(u_v) as coefficients_traversal does. Each face's 2x2
/// determinant is computed three times, once per corner, which costs less than
/// writing a per-face buffer and reading it back through the vertex-face lists.
/// @param[out] weights  if not null, #V: the w_v (the volume is sum_v (x_v - o) w_v
///                      while only the `axis` coordinates change)
/// @param runs  if not null, E's cell runs (cell_runs(E)): the scatter then works
///              run by run in the power form (same coefficients up to rounding)
inline AxisCoefficients coefficients_rings(const BasisTables& T, const Embedding& E, const VertexRings& rings,
                                           const double* X, int axis, const Vector3d& origin, int threads = 0,
                                           bool cone = false, double* weights = nullptr,
                                           const CellRuns* runs = nullptr, bool measure = true) {
  const std::int32_t* ip = rings.indptr.data();
  const std::int32_t* pr = rings.pairs.data();
  return detail::with_axis(axis, [&](auto axis_c) {
    constexpr int ax = decltype(axis_c)::value, a1 = (ax + 1) % 3, a2 = (ax + 2) % 3;
    auto weight_of = [&](Index v) {
      const double* pv = X + 3 * v;
      return detail::ring_weight<ax>(X, ip, pr, v, cone ? origin[a1] : pv[a1], cone ? origin[a2] : pv[a2]);
    };
    return detail::weighted_scatter<ax>(T, E, runs, X, origin[ax], threads, weights, weight_of, measure);
  });
}

/// coefficients_rings for a closed mesh (b = p_v) from the vertices' fans
/// (VertexFans, here in their padded layout: each neighbour read once per vertex,
/// not twice, in loops of fixed length): the same coefficients, volume and weights
/// up to rounding (the terms are added in fan order). The frame's coefficient pass
/// on closed meshes.
///
/// Two passes: every vertex's weight (fan_weights, in the rows' order), then the
/// scatter and the volume in processing order. The results do not depend on the
/// rows' order. Row by row the weight loop reads the fans in order; through the
/// scatter's processing order (where the weights used to be computed, a block at a
/// time) it could not visit them sorted by valence.
/// @param row_vertex  if not null, #V: fan row -> vertex (processing position)
/// @param weights  if not null, #V: receives the w_v (else a buffer is allocated;
///                 a frame passes one for all its steps)
/// @param measure  false: the volume is left 0 (weighted_scatter)
inline AxisCoefficients coefficients_fans(const BasisTables& T, const Embedding& E, const PaddedFans& fans,
                                          const double* X, int axis, const Vector3d& origin, int threads = 0,
                                          double* weights = nullptr, const CellRuns* runs = nullptr,
                                          const std::int32_t* row_vertex = nullptr, bool measure = true) {
  VPFFD_CHECK(fans.size() == E.size() && fans.width >= 1, "coefficients_fans: fans of ", fans.size(),
              " vertices, the embedding has ", E.size());
  std::vector<double> own;
  if (!weights) {
    own.resize(fans.size());
    weights = own.data();
  }
  const double* w = weights;
  return detail::with_axis(axis, [&](auto axis_c) {
    constexpr int ax = decltype(axis_c)::value;
    detail::fan_weights<ax>(X, fans, row_vertex, weights, threads);
    return detail::weighted_scatter<ax>(
        T, E, runs, X, origin[ax], threads, nullptr, [w](Index v) { return w[v]; }, measure);
  });
}

/// The paper's formulation: alpha = A n with A the N x F face matrix
/// (face_basis_matrix) and n the face normal components; OpenMP CSR SpMV.
inline AxisCoefficients coefficients_csr(const CsrMatrix& A, const double* X, const Eigen::Ref<const RowMatrixX3i>& F,
                                         int axis, const Vector3d& origin, int threads = 0) {
  const Index nfaces = F.rows();
  std::vector<double> nf(nfaces);
  face_normal_component(X, F, axis, nf.data(), threads);
  AxisCoefficients out;
  out.alpha.resize(A.rows);
  spmv(A, nf.data(), out.alpha.data(), threads);
  const int chunks = chunk_count(nfaces);
  std::vector<double> vol(chunks, 0.0);
  const double o = origin[axis];
  parallel_chunks(nfaces, chunks, threads, [&](int c, Index b, Index e) {
    double s = 0;
    for (Index f = b; f < e; ++f)
      s += (X[3 * Index(F(f, 0)) + axis] + X[3 * Index(F(f, 1)) + axis] + X[3 * Index(F(f, 2)) + axis] - 3 * o) *
           nf[f];
    vol[c] = s / 6.0;
  });
  for (double v : vol) out.volume += v;
  return out;
}

}  // namespace vpffd
