#pragma once
/// @file rbf_regions.h
/// Paper 002, Section 6's editing setting (after Botsch and Kobbelt 2005): the user
/// paints a deformable region and K handle regions inside it; each handle region
/// moves by an affine map T_k, the rest of the mesh stays where it is, and the
/// deformable region follows a triharmonic RBF map r (rbf.h) of its base.
///
/// Constraints: the base vertices of every handle region (target T_k h_j) and of the
/// fixed vertices within `fixed_rings` edges of the deformable region (target h_j:
/// the fixed boundary is a handle too). Write T_k = [I + D_k; 0 1] with the 3 x 4
/// displacement D_k. The identity targets are reproduced exactly by the RBF's
/// linear part (W = 0), and the solve is linear in the targets, so with
/// beta_E(x) = X_E^T phi(x) for the solution X_E of M X_E = E,
///
///   r(x) = x + sum_k D_k beta_k(x),  E_k = (h_j^T, 1) on region k's rows, 0 elsewhere.
///
/// Every constraint row belongs to one region or to the fixed set, so
/// beta_1 = x~ - beta_f - sum_{k>=2} beta_k (x~ = (x, 1), beta_f of the fixed rows'
/// (h_j^T, 1)) and
///
///   r(x) = x + D_1 alpha_1(x) + sum_{k>=2} (D_k - D_1) alpha_k(x),
///   alpha_1 = x~ - beta_f,  alpha_k = beta_k (k >= 2),
///
/// and J_r(x) s = s + the same with alpha's directional derivatives along s
/// (s~ = (s, 0)). That form is what is stored: without a fixed part beta_f is zero,
/// alpha_1 = x~ exactly, and one motion of every handle region is that motion to
/// rounding, however ill-conditioned the solves of the other alpha_k are (their
/// weights, up to thousands of times the displacements for dense constraint sets,
/// multiply D_k - D_1 = 0). alpha_k are evaluated once here at every free vertex's
/// foot point (for S_u and S_v) and base vertex, phi(x) = (|x_n - c_j|^3, x_n, 1)
/// the RBF basis row: 16 K doubles per free vertex. A frame is then O(V K): no term
/// of it depends on the number of constraint points, and T_k = I leaves the base
/// of every free vertex bit for bit where it was.
///
/// Per vertex a frame does: fixed vertices keep their rest position and normal;
/// handle vertices move rigidly with their region (p' = T_k p, n' along
/// cof(A_k) n, the normal of the affinely mapped surface); free vertices are rebuilt
/// from S' = r(S), S'_u = J_r S_u, S'_v = J_r S_v (reconstruct_vertex).

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "vpffd/core/check.h"
#include "vpffd/core/parallel.h"
#include "vpffd/multires/rbf.h"
#include "vpffd/multires/rbf_constraints.h"
#include "vpffd/multires/reconstruct.h"

namespace vpffd {

using Matrix4d = Eigen::Matrix4d;

/// Most handle regions (each adds 16 doubles per free vertex).
inline constexpr Index kMaxRbfRegions = 64;
/// Most rings of fixed constraints around the deformable region.
inline constexpr int kMaxFixedRings = 64;

namespace detail {

/// Checks that T (region k, 1-based) is a finite, non-singular affine map.
inline void check_affine(const Matrix4d& T, Index k) {
  VPFFD_CHECK(T.allFinite(), "RBF regions: the transform of handle region ", k, " contains NaN or Inf");
  const Matrix3d A = T.topLeftCorner<3, 3>();
  const double s = A.norm() / std::sqrt(3.0);  // 1 for a rotation, the scale factor of a similarity
  VPFFD_CHECK(T(3, 0) == 0 && T(3, 1) == 0 && T(3, 2) == 0 && T(3, 3) == 1, "RBF regions: the transform of handle "
              "region ", k, " is not affine: its last row is (", T(3, 0), ", ", T(3, 1), ", ", T(3, 2), ", ", T(3, 3),
              "), expected (0, 0, 0, 1)");
  const double det = A.determinant();
  VPFFD_CHECK(s > 0 && std::abs(det) > 1e-12 * s * s * s, "RBF regions: the transform of handle region ", k,
              " is singular (det of its 3x3 part ", det, ", scale ", s,
              "): it would flatten the handle and its normals are undefined");
}

}  // namespace detail

/// Precomputed RBF deformation basis of one painted setting; frames take K affine maps.
class RbfRegions {
 public:
  /// @param[in] m           the decomposition (kept; not modified)
  /// @param[in] deformable  #V flags, nonzero for the painted deformable region
  /// @param[in] handles     K >= 1 lists of vertex indices, inside the deformable
  ///                        region, pairwise disjoint, none empty
  /// @param[in] fixed_rings rings of fixed vertices around the deformable region
  ///                        that constrain r to the identity (0..64)
  /// @param[in] spacing     least distance between two constraint points of one
  ///                        region (or of the fixed rings), world units: the base
  ///                        vertices are thinned greedily to it (0: every vertex).
  ///                        The system's condition grows fast as constraints crowd
  ///                        together; a scan's dense handle needs a few edge lengths.
  /// @throws InvalidInputError naming the problem: wrong mask length, empty
  ///         deformable region, empty/out-of-range/overlapping handle regions, a
  ///         handle vertex outside the deformable region, no free vertex left,
  ///         constraint points the RBF cannot interpolate (too few, coplanar,
  ///         duplicates); SolverError for a numerically singular system
  RbfRegions(std::shared_ptr<const Multires> m, const std::vector<std::uint8_t>& deformable,
             const std::vector<std::vector<Index>>& handles, int fixed_rings = 2, double spacing = 0,
             int threads = 0)
      : m_(std::move(m)) {
    VPFFD_CHECK(m_ != nullptr, "RBF regions: no decomposition");
    const Index nv = m_->n_vertices();
    VPFFD_CHECK(Index(deformable.size()) == nv, "RBF regions: the deformable mask has ", deformable.size(),
                " entries for a mesh of ", nv, " vertices");
    VPFFD_CHECK(fixed_rings >= 0 && fixed_rings <= kMaxFixedRings, "RBF regions: fixed_rings ", fixed_rings,
                ", expected 0..", kMaxFixedRings);
    const double diag = (m_->base.colwise().maxCoeff() - m_->base.colwise().minCoeff()).norm();
    VPFFD_CHECK(std::isfinite(spacing) && (spacing == 0 || spacing >= 1e-9 * diag), "RBF regions: spacing ", spacing,
                ", expected 0 or a finite length of at least 1e-9 of the base's diagonal (", diag, ")");
    const Index K = static_cast<Index>(handles.size());
    VPFFD_CHECK(K >= 1, "RBF regions: no handle region; at least one is needed");
    VPFFD_CHECK(K <= kMaxRbfRegions, "RBF regions: ", K, " handle regions; at most ", kMaxRbfRegions);
    Index n_def = 0;
    for (std::uint8_t f : deformable) n_def += f != 0;
    VPFFD_CHECK(n_def > 0, "RBF regions: the deformable region is empty (no vertex of the mask is set)");
    label_.assign(nv, -1);
    for (Index i = 0; i < nv; ++i)
      if (deformable[i]) label_[i] = 0;
    for (Index k = 0; k < K; ++k) {
      VPFFD_CHECK(!handles[k].empty(), "RBF regions: handle region ", k + 1, " is empty");
      for (Index i : handles[k]) {
        VPFFD_CHECK(i >= 0 && i < nv, "RBF regions: handle region ", k + 1, " has vertex ", i,
                    ", outside 0..", nv - 1);
        VPFFD_CHECK(label_[i] >= 0, "RBF regions: vertex ", i, " of handle region ", k + 1,
                    " is outside the deformable region");
        VPFFD_CHECK(label_[i] == 0 || label_[i] == k + 1, "RBF regions: vertex ", i, " is in handle regions ",
                    label_[i], " and ", k + 1, "; handle regions must not overlap");
        if (label_[i] == 0) label_[i] = static_cast<std::int32_t>(k + 1);
      }
    }
    // Each region's constraints: its vertices in the given order (once each), thinned.
    for (Index k = 0; k < K; ++k) {
      std::vector<Index> ids;
      for (Index i : handles[k])
        if (label_[i] == k + 1) {
          ids.push_back(i);
          label_[i] = -2;  // seen
        }
      for (Index i : ids) label_[i] = static_cast<std::int32_t>(k + 1);
      for (Index i : detail::thin_points(m_->base, ids, spacing)) {
        constraint_.push_back(i);
        constraint_region_.push_back(static_cast<std::int32_t>(k + 1));
      }
    }
    for (Index i = 0; i < nv; ++i)
      if (label_[i] == 0) free_.push_back(i);
    VPFFD_CHECK(!free_.empty(), "RBF regions: the handle regions cover the whole deformable region (", n_def,
                " vertices); no vertex is left to deform");
    std::vector<std::uint8_t> inside(nv);
    for (Index i = 0; i < nv; ++i) inside[i] = label_[i] >= 0;
    for (Index i : detail::thin_points(m_->base, detail::ring_vertices(m_->faces, nv, inside, fixed_rings), spacing)) {
      constraint_.push_back(i);
      constraint_region_.push_back(0);
    }
    n_regions_ = K;
    const Index H = static_cast<Index>(constraint_.size());
    RowMatrixX3d h(H, 3);
    for (Index j = 0; j < H; ++j) h.row(j) = m_->base.row(constraint_[j]);
    points_ = h;
    std::unique_ptr<RbfMap> rbf;
    try {
      rbf = std::make_unique<RbfMap>(h);
    } catch (const InvalidInputError& e) {
      throw InvalidInputError(detail::concat("RBF regions: the ", H, " constraint points (", H - fixed_count(),
                                             " base vertices of the ", K, " handle regions, ", fixed_count(),
                                             " of the fixed rings) cannot be interpolated: ", e.what()));
    } catch (const SolverError& e) {
      throw SolverError(detail::concat("RBF regions: the ", H, " constraint points (spacing ", spacing,
                                       ") crowd together: ", e.what(), "; thin them with a larger spacing"));
    }
    // Column groups of E: 0 the fixed rows' (h_j^T, 1), k >= 1 region k + 1's (see the file comment).
    Eigen::MatrixXd E = Eigen::MatrixXd::Zero(H + 4, 4 * K);
    for (Index j = 0; j < H; ++j) {
      const Index k = constraint_region_[j];
      if (k == 1) continue;
      const Index g = k == 0 ? 0 : k - 1;
      E.block<1, 3>(j, 4 * g) = h.row(j);
      E(j, 4 * g + 3) = 1.0;
    }
    const Eigen::MatrixXd Xs = rbf->solve_columns(E);
    precompute(*rbf, Xs, threads);
  }

  Index n_regions() const { return n_regions_; }
  Index n_free() const { return static_cast<Index>(free_.size()); }
  const Multires& multires() const { return *m_; }
  /// Per vertex: -1 fixed, 0 free (deformed by r), k >= 1 in handle region k.
  const std::vector<std::int32_t>& labels() const { return label_; }
  /// The constraint points' vertex indices: handle regions in order, then the fixed rings.
  const std::vector<Index>& constraint_vertices() const { return constraint_; }
  /// Per constraint point: its region (1..K) or 0 (fixed).
  const std::vector<std::int32_t>& constraint_regions() const { return constraint_region_; }
  /// Constraint points (their base vertices), H x 3: the RbfMap these frames equal.
  const RowMatrixX3d& constraint_points() const { return points_; }
  /// Doubles kept per free vertex: alpha_k at the foot point and base vertex, and along S_u, S_v.
  Index doubles_per_free_vertex() const { return 16 * n_regions_; }
  /// The precomputed basis, #free x 16K (free vertices ascending, the labels' zeros):
  /// per row [alpha_k(S) | along S_u | along S_v | alpha_k(base)], 4 doubles per k, world
  /// units (what a device frame uploads).
  const RowMatrixXd& basis() const { return coef_; }

  /// The constraint targets of the transforms T (K maps): T_k h_j, or h_j for fixed
  /// points (H x 3): the general RBF solve that a frame equals.
  RowMatrixX3d targets(const std::vector<Matrix4d>& T) const {
    check_transforms(T);
    RowMatrixX3d out = points_;
    for (Index j = 0; j < out.rows(); ++j) {
      const Index k = constraint_region_[j];
      if (k > 0)
        out.row(j) = (T[k - 1].topLeftCorner<3, 3>() * points_.row(j).transpose() + T[k - 1].topRightCorner<3, 1>())
                         .transpose();
    }
    return out;
  }

  /// One frame: fine vertices X, unit normals N and base vertices B (#V x 3
  /// row-major each) for the K affine maps T (4 x 4, last row (0, 0, 0, 1)).
  /// @throws InvalidInputError for a wrong count, NaN, a non-affine or singular map
  void deform(const std::vector<Matrix4d>& T, double* X, double* N, double* B, int threads = 0) const {
    check_transforms(T);
    const Index K = n_regions_;
    // D[0] = D_1, D[k] = D_{k+1} - D_1: the multipliers of alpha_1, alpha_{k+1}.
    std::vector<Eigen::Matrix<double, 3, 4>> D(K);
    std::vector<Matrix3d> cof(K);
    for (Index k = 0; k < K; ++k) {
      D[k] = T[k].topRows<3>();
      D[k].leftCols<3>() -= Matrix3d::Identity();
      if (k > 0) D[k] -= T[0].topRows<3>() - Eigen::Matrix<double, 3, 4>::Identity();
      const Matrix3d A = T[k].topLeftCorner<3, 3>();
      cof[k] = A.determinant() * A.inverse().transpose();  // maps normals like cross products
    }
    const Multires& m = *m_;
    const Index nv = m.n_vertices();
    // Fixed and handle vertices: no RBF.
    parallel_range(nv, threads, [&](Index b, Index e) {
      for (Index i = b; i < e; ++i) {
        const std::int32_t l = label_[i];
        if (l == 0) continue;
        Vector3d p = m.fine.row(i).transpose(), n = m.rest_normals.row(i).transpose(), q = m.base.row(i).transpose();
        if (l > 0) {
          const Matrix4d& t = T[l - 1];
          p = t.topLeftCorner<3, 3>() * p + t.topRightCorner<3, 1>();
          q = t.topLeftCorner<3, 3>() * q + t.topRightCorner<3, 1>();
          n = (cof[l - 1] * n).normalized();
        }
        for (int a = 0; a < 3; ++a) {
          X[3 * i + a] = p[a];
          N[3 * i + a] = n[a];
          B[3 * i + a] = q[a];
        }
      }
    });
    // Free vertices: S' = S + sum_k D[k] alpha_k, the tangents likewise, then eq. 1 and eqs. 6-7.
    const Index nf = n_free();
    parallel_range(nf, threads, [&](Index b, Index e) {
      for (Index f = b; f < e; ++f) {
        const Index i = free_[f];
        const double* c = coef_.data() + f * 16 * K;
        Vector3d s = m.foot_point(i), su = m.tangent_u(i), sv = m.tangent_v(i), q = m.base.row(i).transpose();
        for (Index k = 0; k < K; ++k) {
          s += D[k] * Eigen::Map<const Eigen::Vector4d>(c + 4 * k);
          su += D[k] * Eigen::Map<const Eigen::Vector4d>(c + 4 * (K + k));
          sv += D[k] * Eigen::Map<const Eigen::Vector4d>(c + 4 * (2 * K + k));
          q += D[k] * Eigen::Map<const Eigen::Vector4d>(c + 4 * (3 * K + k));
        }
        Vector3d p, n;
        reconstruct_vertex(s, su, sv, m.d[i], m.coefficients(i), p, n);
        for (int a = 0; a < 3; ++a) {
          X[3 * i + a] = p[a];
          N[3 * i + a] = n[a];
          B[3 * i + a] = q[a];
        }
      }
    });
  }

 private:
  Index fixed_count() const {
    Index n = 0;
    for (std::int32_t r : constraint_region_) n += r == 0;
    return n;
  }

  void check_transforms(const std::vector<Matrix4d>& T) const {
    VPFFD_CHECK(Index(T.size()) == n_regions_, "RBF regions: ", T.size(), " transforms for ", n_regions_,
                " handle regions");
    for (Index k = 0; k < n_regions_; ++k) detail::check_affine(T[k], k + 1);
  }

  /// alpha_k at every free vertex: rows of the RBF basis phi (and its directional
  /// derivatives along S_u, S_v) times X, kRbfChunk vertices at a time.
  void precompute(const RbfMap& rbf, const Eigen::MatrixXd& Xs, int threads) {
    const Multires& m = *m_;
    const Index K = n_regions_, H = rbf.n_handles(), nf = n_free(), cols = 4 * K;
    const RowMatrixX3d& c = rbf.centres();
    const Vector3d centre = rbf.centre();
    const double inv = 1.0 / rbf.scale();
    coef_.resize(nf, 16 * K);
    // Rows per work item: the basis block P (4 rows per vertex, H + 4 columns) stays
    // within ~8 MB per thread up to kMaxRbfHandles. Each output row is its own dot
    // products, so the chunking does not change the result.
    const Index chunk = std::clamp<Index>(Index(1 << 18) / (H + 4), 4, kRbfChunk);
    const Index chunks = (nf + chunk - 1) / chunk;
    parallel_items(chunks, nf * H, threads, [&](Index ch) {
      const Index b = ch * chunk, e = std::min(nf, b + chunk), nb = e - b;
      // Rows: [foot points | S_u derivatives | S_v derivatives | base vertices] of this chunk.
      Eigen::MatrixXd P(4 * nb, H + 4);
      for (Index r = 0; r < nb; ++r) {
        const Index i = free_[b + r];
        const Vector3d x = (m.foot_point(i) - centre) * inv, xb = (m.base.row(i).transpose() - centre) * inv;
        const Vector3d su = m.tangent_u(i) * inv, sv = m.tangent_v(i) * inv;  // d x_n along S_u, S_v
        for (Index j = 0; j < H; ++j) {
          const Vector3d d = x - c.row(j).transpose();
          const double len = d.norm();
          P(r, j) = len * len * len;
          P(nb + r, j) = 3.0 * len * d.dot(su);
          P(2 * nb + r, j) = 3.0 * len * d.dot(sv);
          const double lb = (xb - c.row(j).transpose()).norm();
          P(3 * nb + r, j) = lb * lb * lb;
        }
        P.block<1, 4>(r, H) << x.transpose(), 1.0;
        P.block<1, 4>(nb + r, H) << su.transpose(), 0.0;
        P.block<1, 4>(2 * nb + r, H) << sv.transpose(), 0.0;
        P.block<1, 4>(3 * nb + r, H) << xb.transpose(), 1.0;
      }
      // 4 nb x 4K: beta_f, beta_2.. beta_K per row. A lazy (coefficient-wise) product:
      // Eigen's blocked GEMM splits its sums by the OpenMP threads it finds, which
      // differ inside and outside parallel_items, and the basis must not depend on them.
      const Eigen::MatrixXd Y = P.lazyProduct(Xs);
      for (Index r = 0; r < nb; ++r) {
        const Index i = free_[b + r];
        // alpha_1 = x~ - beta_f for the foot point, S_u, S_v (s~ = (s, 0)) and the base vertex.
        const Eigen::Vector4d tilde[4] = {{m.foot[0][i], m.foot[1][i], m.foot[2][i], 1.0},
                                          {m.su[0][i], m.su[1][i], m.su[2][i], 0.0},
                                          {m.sv[0][i], m.sv[1][i], m.sv[2][i], 0.0},
                                          {m.base(i, 0), m.base(i, 1), m.base(i, 2), 1.0}};
        for (int q = 0; q < 4; ++q) {
          coef_.block(b + r, q * cols, 1, cols) = Y.row(q * nb + r);
          coef_.block<1, 4>(b + r, q * cols) = (tilde[q] - Y.row(q * nb + r).head<4>().transpose()).transpose();
        }
      }
    });
  }

  std::shared_ptr<const Multires> m_;
  Index n_regions_ = 0;
  std::vector<std::int32_t> label_;             ///< per vertex: -1 fixed, 0 free, k handle region
  std::vector<Index> free_;                     ///< free vertices, ascending
  std::vector<Index> constraint_;               ///< constraint points' vertices
  std::vector<std::int32_t> constraint_region_;  ///< their regions (0: fixed)
  RowMatrixX3d points_;                         ///< constraint points (base vertices)
  RowMatrixXd coef_;  ///< #free x 16K: [alpha_k(S) | along S_u | along S_v | alpha_k(base)], 4 per k
};

}  // namespace vpffd
