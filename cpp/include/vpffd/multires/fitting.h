#pragma once
/// @file fitting.h
/// Fitting a base surface to a fine mesh (paper 002, §4.1, after Marinov & Kobbelt):
/// the base is linear in its control points C (N x 3) at fixed foot-point
/// parameters, S(t_i) = sum_j Phi_ij C_j, so shortening the displacements is a
/// linear least-squares problem with a fairness term,
///
///   minimise  sum_i w_i |(Phi C)_i - P_i|^2  +  lambda' |C|_K^2  +  mu |C - C0|^2,
///
/// solved from the normal equations (Phi^T W Phi + lambda' K + mu I) C = Phi^T W P + mu C0.
/// The row weights w_i (default 1) let a caller pull the surface harder toward the
/// points it has not reached (vertices with no exact foot point).
/// Both the smooth-mesh base (Phi: the barycentric coordinates of each foot point in
/// its base triangle) and the subdivision base (Phi: limit stencils) use it,
/// alternating with a foot-point update that changes Phi.
///
/// Units: lambda is relative. lambda' = lambda * trace(Phi^T W Phi) / trace(K), so the
/// balance between closeness and fairness does not depend on the mesh size, the
/// number of control points or the units of K. The proximal term mu |C - C0|^2
/// (mu = 1e-9 of the mean diagonal of Phi^T Phi) only makes the system definite
/// when some control point influences no foot point and K does not tie it down; it
/// moves the solution by about 1e-9 of a control point's displacement.

#include <cmath>
#include <vector>

#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>

#include "vpffd/core/check.h"
#include "vpffd/core/exceptions.h"
#include "vpffd/core/types.h"
#include "vpffd/sparse/pcg.h"

namespace vpffd {

/// What fit_control_points did.
struct FitReport {
  double rms_before = 0;  ///< RMS of |(Phi C0)_i - P_i| over the rows, world units
  double rms_after = 0;   ///< the same for the fitted C
  int iterations = 0;     ///< CG iterations (0 when the factorisation solved it)
  bool direct = false;    ///< solved by sparse Cholesky (CG did not converge)
};

namespace detail {

inline double rms_rows(const RowSparse& Phi, const RowMatrixX3d& C, const Eigen::Ref<const RowMatrixX3d>& P) {
  if (P.rows() == 0) return 0;
  const RowMatrixX3d r = Phi * C - P;
  return std::sqrt(r.squaredNorm() / double(P.rows()));
}

}  // namespace detail

/// Least-squares control points of a linear base surface (see the file comment).
/// @param Phi  #P x N basis weights of each point's foot parameter (row-major; rows
///             of a partition of unity in both uses, but not required)
/// @param P    #P x 3 points to approach (the fine vertices)
/// @param K    N x N symmetric positive semi-definite fairness form (e.g. the
///             cotangent stiffness of the base mesh or a control-mesh Laplacian)
/// @param lambda  relative fairness weight, >= 0 and finite
/// @param C0   N x 3 current control points: the warm start and the proximal anchor
/// @param threads  for the CG products (the result does not depend on it)
/// @param weights  #P positive finite row weights, or nullptr for all 1
/// @returns N x 3 fitted control points
/// @throws InvalidInputError for mismatched shapes, non-finite input or a negative
///         lambda; SolverError when the system cannot be factorised
inline RowMatrixX3d fit_control_points(const RowSparse& Phi, const Eigen::Ref<const RowMatrixX3d>& P,
                                       const Eigen::SparseMatrix<double>& K, double lambda,
                                       const Eigen::Ref<const RowMatrixX3d>& C0, int threads = 0,
                                       FitReport* report = nullptr, const VectorXd* weights = nullptr) {
  const Index n = Phi.cols();
  VPFFD_CHECK(Phi.rows() == P.rows(), "fit_control_points: ", Phi.rows(), " basis rows for ", P.rows(), " points");
  VPFFD_CHECK(K.rows() == n && K.cols() == n && C0.rows() == n, "fit_control_points: ", n,
              " control points, but K is ", K.rows(), " x ", K.cols(), " and C0 has ", C0.rows(), " rows");
  VPFFD_CHECK(std::isfinite(lambda) && lambda >= 0, "fit_control_points: lambda must be >= 0, got ", lambda);
  VPFFD_CHECK(P.allFinite() && C0.allFinite(), "fit_control_points: the points contain NaN or infinity");
  VPFFD_CHECK(n > 0, "fit_control_points: no control points");
  VPFFD_CHECK(!weights || (weights->size() == P.rows() && weights->allFinite() && weights->minCoeff() > 0),
              "fit_control_points: expected ", P.rows(), " positive finite weights");
  RowSparse PhiW = Phi;  // W Phi
  if (weights) PhiW = weights->asDiagonal() * Phi;
  RowSparse A = RowSparse(PhiW.transpose()) * Phi;
  const double trace_phi = A.diagonal().sum();
  const double trace_k = K.diagonal().sum();
  VPFFD_CHECK(trace_phi > 0, "fit_control_points: no point depends on any control point");
  if (lambda > 0 && trace_k > 0) A += RowSparse(K) * (lambda * trace_phi / trace_k);
  const double mu = 1e-9 * trace_phi / double(n);
  RowSparse I(n, n);
  I.setIdentity();
  A += I * mu;
  A.makeCompressed();
  const RowMatrixX3d B = RowMatrixX3d(PhiW.transpose() * P) + mu * C0;

  FitReport rep;
  rep.rms_before = detail::rms_rows(Phi, C0, P);
  RowMatrixX3d C = C0;
  // The tolerance is relative to |B|: 1e-10 leaves an error of cond(A) * 1e-10 of
  // the control points' size (cond ~ 1 + 16 lambda for the umbrella form), far below
  // the displacements the fit shortens (1e-4 of the size on scans).
  const PcgReport cg = pcg_solve3(A, B, C, 1e-10, 2000, threads);
  rep.iterations = cg.iterations;
  if (!cg.converged) {
    const Eigen::SparseMatrix<double> Ac = A;
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(Ac);
    if (ldlt.info() != Eigen::Success) throw SolverError("fit_control_points: the normal equations are singular");
    C = ldlt.solve(Eigen::MatrixXd(B));
    rep.direct = true;
    rep.iterations = 0;
  }
  VPFFD_CHECK(C.allFinite(), "fit_control_points: the fit is not finite");
  rep.rms_after = detail::rms_rows(Phi, C, P);
  if (report) *report = rep;
  return C;
}

/// Thin-plate fairness form K = L^T L of the umbrella (uniform) Laplacian of a
/// triangle mesh, L = I - (mean of the edge neighbours). It penalises the bending of
/// the control net, not its size, so a fitted base keeps thin parts thin instead of
/// shrinking them, and its conditioning depends on the vertex degrees, not on the
/// triangle shapes (a scan's slivers make cotangent weights arbitrarily large).
/// Vertices in no edge get a zero row.
/// @param F  #F x 3 triangles over n vertices
inline Eigen::SparseMatrix<double> umbrella_fairness(const Eigen::Ref<const RowMatrixX3i>& F, Index n) {
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(static_cast<size_t>(F.rows()) * 6);
  for (Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      // Each undirected edge appears in two faces of a closed mesh: weight 1 per
      // face side, so the neighbour weights are counted consistently and normalised
      // by the row sum below.
      t.emplace_back(F(f, c), F(f, (c + 1) % 3), 1.0);
      t.emplace_back(F(f, (c + 1) % 3), F(f, c), 1.0);
    }
  Eigen::SparseMatrix<double, Eigen::RowMajor> A(n, n);
  A.setFromTriplets(t.begin(), t.end());
  for (Index i = 0; i < n; ++i) {
    double sum = 0;
    for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(A, i); it; ++it) sum += it.value();
    for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(A, i); it; ++it) it.valueRef() /= -sum;
  }
  Eigen::SparseMatrix<double> I(n, n);
  I.setIdentity();
  for (Index i = 0; i < n; ++i)
    if (A.row(i).nonZeros() == 0) I.coeffRef(i, i) = 0;
  const Eigen::SparseMatrix<double> L = Eigen::SparseMatrix<double>(A) + I;
  return Eigen::SparseMatrix<double>(L.transpose() * L);
}

/// Tangential residual of a foot point: the part of p - S orthogonal to the unit
/// normal n, |(p - S) - ((p - S) . n) n|, in world units. An exact foot point
/// (eq. 1: p - S parallel to n) has 0.
inline double tangential_residual(const Vector3d& p, const Vector3d& S, const Vector3d& n) {
  const Vector3d r = p - S;
  return (r - r.dot(n) * n).norm();
}

/// A foot point is exact when its tangential residual is at most this fraction of
/// the mesh's bounding-box diagonal. Newton steps reach ~1e-15 relative where a
/// foot point exists; 1e-9 leaves six orders of magnitude for conditioning.
inline constexpr double kFootPointTolerance = 1e-9;

}  // namespace vpffd
