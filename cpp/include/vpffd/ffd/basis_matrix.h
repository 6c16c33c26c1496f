#pragma once
/// @file basis_matrix.h
/// The explicit sparse matrices of the FFD: the vertex basis matrix B (#V x N,
/// the FFD is V = B P) and the paper's face matrix (N x F, Section 6.2) whose
/// entry (c, f) is (B_c(u_l) + B_c(u_m) + B_c(u_n)) / 6 for face f = (l, m, n).

#include <algorithm>

#include "vpffd/core/parallel.h"
#include "vpffd/ffd/vertex_basis.h"
#include "vpffd/sparse/csr.h"

namespace vpffd {

/// Writes the (K_u K_v K_w) control indices and basis values of point v, in increasing index order.
inline int point_basis_entries(const BasisTables& T, const Embedding& E, Index v, std::int32_t* idx, double* val) {
  double bu[detail::kMaxOrder], bv[detail::kMaxOrder], bw[detail::kMaxOrder];
  const Index base = detail::point_basis<0>(T, E, v, bu, bv, bw);
  const Index sj = T.dims[2], si = Index(T.dims[1]) * T.dims[2];
  int n = 0;
  for (int i = 0; i < T.order[0]; ++i)
    for (int j = 0; j < T.order[1]; ++j)
      for (int k = 0; k < T.order[2]; ++k) {
        idx[n] = static_cast<std::int32_t>(base + i * si + j * sj + k);
        val[n++] = bu[i] * bv[j] * bw[k];
      }
  return n;
}

/// #points x N basis matrix (all (d+1)^3 structural entries per row, zeros included).
inline CsrMatrix vertex_basis_matrix(const BasisTables& T, const Embedding& E, int threads = 0) {
  const Index n = E.size();
  const int per = T.order[0] * T.order[1] * T.order[2];
  CsrMatrix A;
  A.rows = n;
  A.cols = Index(T.dims[0]) * T.dims[1] * T.dims[2];
  A.indptr.resize(n + 1);
  for (Index v = 0; v <= n; ++v) A.indptr[v] = v * per;
  A.indices.resize(static_cast<size_t>(n) * per);
  A.values.resize(static_cast<size_t>(n) * per);
  parallel_range(n, threads, [&](Index b, Index e) {
    for (Index v = b; v < e; ++v) point_basis_entries(T, E, v, &A.indices[v * per], &A.values[v * per]);
  });
  return A;
}

/// The paper's N x F matrix. Built column by column (per face, merging the three
/// vertex supports), then transposed by a counting sort. For the dragon this is
/// about 56 M entries (0.7 GB); the traversal method needs none of it.
inline CsrMatrix face_basis_matrix(const BasisTables& T, const Embedding& E, const Eigen::Ref<const RowMatrixX3i>& F,
                                   int threads = 0) {
  const Index nf = F.rows();
  const Index N = Index(T.dims[0]) * T.dims[1] * T.dims[2];
  const int per = T.order[0] * T.order[1] * T.order[2];
  // Pass 1: the merged support of each face (a face-major matrix, F x N).
  std::vector<std::int64_t> fptr(nf + 1, 0);
  auto merge = [&](Index f, std::int32_t* oi, double* ov) {
    std::int32_t idx[3][216];
    double val[3][216];
    for (int c = 0; c < 3; ++c) point_basis_entries(T, E, F(f, c), idx[c], val[c]);
    int p[3] = {0, 0, 0}, n = 0;
    while (true) {
      std::int32_t m = INT32_MAX;
      for (int c = 0; c < 3; ++c)
        if (p[c] < per) m = std::min(m, idx[c][p[c]]);
      if (m == INT32_MAX) break;
      double s = 0;
      for (int c = 0; c < 3; ++c)
        if (p[c] < per && idx[c][p[c]] == m) s += val[c][p[c]++];
      if (oi) {
        oi[n] = m;
        ov[n] = s / 6.0;
      }
      ++n;
    }
    return n;
  };
  parallel_range(nf, threads, [&](Index b, Index e) {
    for (Index f = b; f < e; ++f) fptr[f + 1] = merge(f, nullptr, nullptr);
  });
  for (Index f = 0; f < nf; ++f) fptr[f + 1] += fptr[f];
  std::vector<std::int32_t> fidx(fptr.back());
  std::vector<double> fval(fptr.back());
  parallel_range(nf, threads, [&](Index b, Index e) {
    for (Index f = b; f < e; ++f) merge(f, &fidx[fptr[f]], &fval[fptr[f]]);
  });
  // Pass 2: transpose to N x F; faces come in order, so columns stay sorted.
  CsrMatrix A;
  A.rows = N;
  A.cols = nf;
  A.indptr.assign(N + 1, 0);
  for (std::int32_t c : fidx) ++A.indptr[c + 1];
  for (Index r = 0; r < N; ++r) A.indptr[r + 1] += A.indptr[r];
  A.indices.resize(fidx.size());
  A.values.resize(fidx.size());
  std::vector<std::int64_t> fill(A.indptr.begin(), A.indptr.end() - 1);
  for (Index f = 0; f < nf; ++f)
    for (std::int64_t p = fptr[f]; p < fptr[f + 1]; ++p) {
      const std::int64_t q = fill[fidx[p]]++;
      A.indices[q] = static_cast<std::int32_t>(f);
      A.values[q] = fval[p];
    }
  return A;
}

}  // namespace vpffd
