#pragma once
/// @file rbf.h
/// Triharmonic radial-basis space deformation (paper 002, Section 6, after Botsch
/// and Kobbelt 2005): r(x) = sum_j w_j |x - c_j|^3 + A x + b, centres c_j at the
/// handle points, interpolating r(h_j) = h'_j with the side conditions
/// sum_j w_j = 0, sum_j w_j c_j^T = 0:
///
///   [Phi  Pi] [W      ]   [H']
///   [Pi^T  0] [(A b)^T] = [0 ],  Phi_jk = |h_j - h_k|^3,  Pi_j = (h_j^T, 1).
///
/// The (H+4)^2 matrix depends only on the handles: it is LU-factorised once per
/// handle set, and each new set of targets is a back-substitution (plus one step
/// of iterative refinement). r^3 is conditionally positive definite of order 2, so
/// the matrix is non-singular exactly when the handles are distinct and not
/// coplanar (the linear polynomial must be determined by them): both are checked
/// up front and refused by name rather than solved into NaN.
/// Jacobian: J_r(x) = sum_j 3 |x - c_j| w_j (x - c_j)^T + A.
///
/// The system is built in normalised coordinates (handles centred on their mean and
/// divided by their bounding-box diagonal): otherwise the r^3 block and the
/// polynomial block differ by the cube of the mesh's size, and the conditioning
/// (and the singularity test) would depend on units.

#include <cmath>
#include <limits>

#include <Eigen/LU>
#include <Eigen/SVD>

#include "vpffd/core/check.h"
#include "vpffd/core/exceptions.h"
#include "vpffd/core/parallel.h"
#include "vpffd/core/types.h"
#include "vpffd/multires/rbf_kernel.h"

namespace vpffd {

/// Most handles a dense (H+4)^2 factorisation is accepted for (~800 MB at the limit).
inline constexpr Index kMaxRbfHandles = 10000;

/// The weights of one solved RBF map: W (H x 3) and the affine part A, b.
struct RbfWeights {
  RowMatrixX3d w;  ///< H x 3 kernel weights
  Matrix3d A = Matrix3d::Identity();
  Vector3d b = Vector3d::Zero();
};
// (w, A, b) act on normalised coordinates (see RbfMap); values come out in world units.

class RbfMap {
 public:
  /// @param[in] handles  H x 3 rest-space handle points (H >= 4, distinct, not coplanar)
  /// @throws InvalidInputError naming the problem: too few handles, non-finite,
  ///         duplicates (closer than 1e-12 of their bounding-box diagonal), all in
  ///         one plane (smallest/largest singular value of the centred handles
  ///         below 1e-9); SolverError if the factorisation is still singular
  explicit RbfMap(const Eigen::Ref<const RowMatrixX3d>& handles) : h_(handles) {
    const Index H = h_.rows();
    VPFFD_CHECK(H >= 4, "RBF: ", H, " handles; at least 4 not in one plane are needed (the linear part has 4 "
                        "unknowns per coordinate)");
    VPFFD_CHECK(H <= kMaxRbfHandles, "RBF: ", H, " handles; at most ", kMaxRbfHandles,
                " (the dense (H+4)^2 system would not fit)");
    VPFFD_CHECK(h_.allFinite(), "RBF: handles contain NaN or Inf");
    const double diag = (h_.colwise().maxCoeff() - h_.colwise().minCoeff()).norm();
    VPFFD_CHECK(diag > 0, "RBF: all ", H, " handles are the same point");
    for (Index j = 0; j < H; ++j)
      for (Index k = 0; k < j; ++k)
        VPFFD_CHECK((h_.row(j) - h_.row(k)).norm() > 1e-12 * diag, "RBF: handles ", k, " and ", j,
                    " are the same point (", h_(j, 0), ", ", h_(j, 1), ", ", h_(j, 2),
                    "); the system would be singular");
    centre_ = h_.colwise().mean().transpose();
    scale_ = diag;
    c_ = (h_.rowwise() - centre_.transpose()) / scale_;
    const Eigen::MatrixXd centred = c_;
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(centred);
    const Vector3d sv = svd.singularValues();
    VPFFD_CHECK(sv[2] > 1e-9 * sv[0], "RBF: the ", H,
                " handles lie in one plane (or on a line); the linear part would be undetermined and the system "
                "singular; add a handle off that plane");
    M_ = Eigen::MatrixXd::Zero(H + 4, H + 4);
    for (Index j = 0; j < H; ++j) {
      for (Index k = 0; k < H; ++k) M_(j, k) = std::pow((c_.row(j) - c_.row(k)).norm(), 3);
      for (int a = 0; a < 3; ++a) M_(j, H + a) = M_(H + a, j) = c_(j, a);
      M_(j, H + 3) = M_(H + 3, j) = 1.0;
    }
    lu_.compute(M_);
    const double rc = lu_.rcond();
    if (!(rc > 1e3 * std::numeric_limits<double>::epsilon()))
      throw SolverError(detail::concat("RBF: the handle system is numerically singular (reciprocal condition ", rc,
                                       "); spread the handles out"));
  }

  Index n_handles() const { return c_.rows(); }
  const RowMatrixX3d& handles() const { return h_; }

  /// Normalised centres (H x 3), and the world point and length they are relative to.
  const RowMatrixX3d& centres() const { return c_; }
  const Vector3d& centre() const { return centre_; }
  double scale() const { return scale_; }

  /// Solves M X = rhs for any number of right-hand sides ((H+4) x m), with one step
  /// of iterative refinement (the residual of the first solve, solved again).
  Eigen::MatrixXd solve_columns(const Eigen::MatrixXd& rhs) const {
    VPFFD_CHECK(rhs.rows() == M_.rows(), "RBF: ", rhs.rows(), " right-hand-side rows for a system of ", M_.rows());
    Eigen::MatrixXd x = lu_.solve(rhs);
    x += lu_.solve(rhs - M_ * x);
    return x;
  }

  /// Solves for targets H' (H x 3). @throws InvalidInputError for a wrong shape or NaN
  RbfWeights solve(const Eigen::Ref<const RowMatrixX3d>& targets) const {
    const Index H = c_.rows();
    VPFFD_CHECK(targets.rows() == H, "RBF: ", targets.rows(), " targets for ", H, " handles");
    VPFFD_CHECK(targets.allFinite(), "RBF: targets contain NaN or Inf");
    Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(H + 4, 3);
    rhs.topRows(H) = targets;
    const Eigen::MatrixXd x = solve_columns(rhs);
    RbfWeights W;
    W.w = x.topRows(H);
    W.A = x.middleRows(H, 3).transpose();
    W.b = x.row(H + 3).transpose();
    return W;
  }

  /// The solved map W laid out for the blocked kernel (rbf_kernel.h).
  RbfTerms terms(const RbfWeights& W) const {
    RbfTerms t;
    for (int a = 0; a < 3; ++a) {
      t.c[a].resize(c_.rows());
      t.w[a].resize(c_.rows());
      for (Index j = 0; j < c_.rows(); ++j) {
        t.c[a][j] = c_(j, a);
        t.w[a][j] = W.w(j, a);
      }
    }
    t.A = W.A;
    t.b = W.b;
    t.centre = centre_;
    t.scale = scale_;
    return t;
  }

  /// r(x) and J_r(x) (x in world coordinates; W from solve(), in normalised ones).
  void eval(const RbfWeights& W, const Vector3d& xw, Vector3d& value, Matrix3d& J) const {
    const Vector3d x = (xw - centre_) / scale_;
    Vector3d s = W.A * x + W.b;
    Matrix3d g = W.A;
    for (Index j = 0; j < c_.rows(); ++j) {
      const Vector3d r = x - c_.row(j).transpose();
      const double len = r.norm();
      const Vector3d wj = W.w.row(j).transpose();
      s += (len * len * len) * wj;
      g += (3.0 * len) * wj * r.transpose();
    }
    value = s;
    J = g / scale_;
  }

  /// r at the rows of X (#X x 3), by the blocked kernel (rbf_kernel.h; the same
  /// value as eval() to rounding).
  RowMatrixX3d map(const RbfWeights& W, const Eigen::Ref<const RowMatrixX3d>& X, int threads = 0) const {
    VPFFD_CHECK(X.allFinite(), "RBF: points contain NaN or Inf");
    VPFFD_CHECK(W.w.rows() == c_.rows(), "RBF: weights for ", W.w.rows(), " handles, the map has ", c_.rows());
    RowMatrixX3d out(X.rows(), 3);
    rbf_eval_points(terms(W), X.data(), X.rows(), out.data(), nullptr, threads);
    return out;
  }

  /// r and J_r (#X x 9 row-major) at the rows of X, by the blocked kernel.
  void map_jacobians(const RbfWeights& W, const Eigen::Ref<const RowMatrixX3d>& X, RowMatrixX3d& values,
                     RowMatrixXd& J, int threads = 0) const {
    VPFFD_CHECK(X.allFinite(), "RBF: points contain NaN or Inf");
    VPFFD_CHECK(W.w.rows() == c_.rows(), "RBF: weights for ", W.w.rows(), " handles, the map has ", c_.rows());
    values.resize(X.rows(), 3);
    J.resize(X.rows(), 9);
    rbf_eval_points(terms(W), X.data(), X.rows(), values.data(), J.data(), threads);
  }

 private:
  RowMatrixX3d h_;  ///< handles as given
  RowMatrixX3d c_;  ///< normalised handles (the centres)
  Vector3d centre_;
  double scale_ = 1;
  Eigen::MatrixXd M_;
  Eigen::PartialPivLU<Eigen::MatrixXd> lu_;
};

}  // namespace vpffd
