#pragma once
/// @file pcg.h
/// Jacobi-preconditioned conjugate gradients for A X = B with three right-hand
/// sides at once (the x, y, z columns of a mesh), A sparse symmetric positive definite.
///
/// The three columns share each product A P (the matrix is read once for all three)
/// and have their own step lengths; a column stops moving once its residual meets the
/// tolerance. Every product row and every dot product is summed in a fixed order
/// (rows independently; dot products over chunks fixed by n, combined in chunk order:
/// core/parallel.h), so the result is the same bits for any thread count.

#include <array>
#include <cmath>
#include <vector>

#include <Eigen/Sparse>

#include "vpffd/core/check.h"
#include "vpffd/core/parallel.h"
#include "vpffd/core/types.h"

namespace vpffd {

using RowSparse = Eigen::SparseMatrix<double, Eigen::RowMajor, int>;

struct PcgReport {
  int iterations = 0;
  bool converged = false;
  double relative_residual = 0;  ///< max over the columns of |B - A X| / |B| (recurrence)
  double initial_relative_residual = 0;  ///< the same for the initial guess
};

/// Solves A X = B from the initial guess in X, until |B_c - A X_c| <= tol |B_c| for
/// every column c (2-norms; a zero column gives X_c = 0) or `max_iter` iterations.
/// @param A  n x n symmetric positive definite, row-major, compressed, with its
///           diagonal stored (positive)
/// @param B  n x 3
/// @param[in,out] X  n x 3 initial guess, then the solution
inline PcgReport pcg_solve3(const RowSparse& A, const Eigen::Ref<const RowMatrixX3d>& B, RowMatrixX3d& X, double tol,
                            int max_iter, int threads = 0) {
  const Index n = A.rows();
  // The loops below read the compressed arrays: an uncompressed matrix (after
  // coeffRef inserted an entry) has gaps they would read as entries.
  VPFFD_CHECK(A.isCompressed() && A.cols() == n && B.rows() == n && X.rows() == n,
              "pcg_solve3: needs a compressed square matrix and n x 3 blocks");
  const int* ip = A.outerIndexPtr();
  const int* col = A.innerIndexPtr();
  const double* val = A.valuePtr();
  VectorXd inv_diag(n);
  for (Index i = 0; i < n; ++i) {
    double d = 0;
    for (int k = ip[i]; k < ip[i + 1]; ++k)
      if (col[k] == i) d = val[k];
    VPFFD_CHECK(d > 0, "pcg_solve3: diagonal entry ", i, " is ", d, " (the matrix is not positive definite)");
    inv_diag[i] = 1.0 / d;
  }
  const int chunks = chunk_count(n);
  using Sums = std::array<double, 3>;
  // f(i, sums) per row, sums per chunk, combined in chunk order.
  auto reduce = [&](auto&& f) {
    std::vector<Sums> part(chunks, Sums{0, 0, 0});
    parallel_chunks(n, chunks, threads, [&](int c, Index b, Index e) {
      Sums s{0, 0, 0};
      for (Index i = b; i < e; ++i) f(i, s);
      part[c] = s;
    });
    Sums t{0, 0, 0};
    for (const Sums& p : part)
      for (int c = 0; c < 3; ++c) t[c] += p[c];
    return t;
  };
  auto times_A = [&](const RowMatrixX3d& P, Index i, double* out) {
    double s0 = 0, s1 = 0, s2 = 0;
    for (int k = ip[i]; k < ip[i + 1]; ++k) {
      const double a = val[k];
      const double* p = P.data() + 3 * Index(col[k]);
      s0 += a * p[0];
      s1 += a * p[1];
      s2 += a * p[2];
    }
    out[0] = s0;
    out[1] = s1;
    out[2] = s2;
  };

  RowMatrixX3d R(n, 3), Z(n, 3), P(n, 3), Q(n, 3);
  const Sums bb = reduce([&](Index i, Sums& s) {
    for (int c = 0; c < 3; ++c) s[c] += B(i, c) * B(i, c);
  });
  Sums rz = reduce([&](Index i, Sums& s) {
    double ax[3];
    times_A(X, i, ax);
    for (int c = 0; c < 3; ++c) {
      R(i, c) = B(i, c) - ax[c];
      Z(i, c) = inv_diag[i] * R(i, c);
      P(i, c) = Z(i, c);
      s[c] += R(i, c) * Z(i, c);
    }
  });
  Sums rr = reduce([&](Index i, Sums& s) {
    for (int c = 0; c < 3; ++c) s[c] += R(i, c) * R(i, c);
  });
  std::array<bool, 3> active{};
  PcgReport rep;
  auto check = [&] {
    bool any = false;
    rep.relative_residual = 0;
    for (int c = 0; c < 3; ++c) {
      const double rel = bb[c] > 0 ? std::sqrt(rr[c] / bb[c]) : 0.0;
      active[c] = bb[c] > 0 && !(rel <= tol);
      rep.relative_residual = std::max(rep.relative_residual, rel);
      any |= active[c];
    }
    return any;
  };
  for (int c = 0; c < 3; ++c)
    if (!(bb[c] > 0))
      for (Index i = 0; i < n; ++i) X(i, c) = 0;
  check();
  rep.initial_relative_residual = rep.relative_residual;
  while (check()) {
    if (rep.iterations == max_iter || !std::isfinite(rep.relative_residual)) return rep;
    ++rep.iterations;
    const Sums pq = reduce([&](Index i, Sums& s) {
      times_A(P, i, &Q(i, 0));
      for (int c = 0; c < 3; ++c) s[c] += P(i, c) * Q(i, c);
    });
    Sums alpha{0, 0, 0};
    for (int c = 0; c < 3; ++c) alpha[c] = active[c] ? rz[c] / pq[c] : 0.0;
    Sums both[2];
    {
      std::vector<std::array<double, 6>> part(chunks);
      parallel_chunks(n, chunks, threads, [&](int ch, Index b, Index e) {
        std::array<double, 6> s{};
        for (Index i = b; i < e; ++i)
          for (int c = 0; c < 3; ++c) {
            X(i, c) += alpha[c] * P(i, c);
            R(i, c) -= alpha[c] * Q(i, c);
            Z(i, c) = inv_diag[i] * R(i, c);
            s[c] += R(i, c) * Z(i, c);
            s[3 + c] += R(i, c) * R(i, c);
          }
        part[ch] = s;
      });
      both[0] = both[1] = Sums{0, 0, 0};
      for (const auto& p : part)
        for (int c = 0; c < 3; ++c) {
          both[0][c] += p[c];
          both[1][c] += p[3 + c];
        }
    }
    Sums beta{0, 0, 0};
    for (int c = 0; c < 3; ++c) {
      beta[c] = active[c] ? both[0][c] / rz[c] : 0.0;
      if (active[c]) {
        rz[c] = both[0][c];
        rr[c] = both[1][c];
      }
    }
    parallel_range(n, threads, [&](Index b, Index e) {
      for (Index i = b; i < e; ++i)
        for (int c = 0; c < 3; ++c) P(i, c) = Z(i, c) + beta[c] * P(i, c);
    });
  }
  rep.converged = true;
  return rep;
}

}  // namespace vpffd
