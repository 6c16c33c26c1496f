#pragma once
/// @file ffd_map.h
/// The FFD as a deformer of the base surface (paper 002, Section 6 with an FFD in
/// place of the RBF): S' = D(S(t_i)), S'_u = J_D S_u, S'_v = J_D S_v, with the
/// basis values and first derivatives evaluated at each foot point every frame
/// (the foot point's span and local parameter, 36 bytes, are all it keeps).
///
/// Two kernels give the same frame to rounding: the per-point one (ffd_value_jacobian,
/// basis values and derivatives per foot point, then tensor sums) and, for uniform
/// orders 2..6, the cell-run one (multires/foot_runs.h: the foot points sorted by
/// cell once, each cell's polynomial formed once per run, no per-point basis), which
/// deform() uses; deform_per_point() keeps the first as the reference.
///
/// Periodic lattices: the control points given are the distinct ones, expanded to the
/// extended lattice per frame (lattice/periodic.h), the foot points are wrapped into
/// the box by the embedding, and the seams' translations and mirrors are applied at
/// the foot points (foot_seams.h), as the Deformer does at its vertices.

#include <memory>

#include "vpffd/ffd/kernels.h"
#include "vpffd/ffd/vertex_basis.h"
#include "vpffd/lattice/embed.h"
#include "vpffd/lattice/periodic.h"
#include "vpffd/multires/foot_runs.h"
#include "vpffd/multires/foot_seams.h"
#include "vpffd/multires/reconstruct.h"

namespace vpffd {

namespace detail {

/// D(x) and J = dD/dx (row-major, J[3 r + c] = dD_r/dx_c) at embedded point v.
/// Mixed orders (K = 0) nest the tensor sum (k, then j, then i), each level
/// combining the partial sums inside with values or derivatives of one axis.
template <int K>
VPFFD_ALWAYS_INLINE void ffd_value_jacobian(const BasisTables& T, const Embedding& E, const double* const P[3],
                                            const Vector3d& du_dx, Index v, Vector3d& value, Matrix3d& J) {
  double N[3][kMaxOrder], dN[3][kMaxOrder];
  int ord[3];
  Index first[3];
  for (int a = 0; a < 3; ++a) {
    ord[a] = K > 0 ? K : T.order[a];
    const int s = E.span[a][v];
    eval_span_derivs(T.poly[a].span_coef(s), ord[a], E.tau[a][v], N[a], dN[a]);
    const double scale = T.poly[a].inv_width[s - T.poly[a].first_span] * du_dx[a];
    for (int r = 0; r < ord[a]; ++r) dN[a][r] *= scale;
    first[a] = s - T.poly[a].degree;
  }
  const Index sj = T.dims[2], si = Index(T.dims[1]) * T.dims[2];
  const Index base = (first[0] * T.dims[1] + first[1]) * T.dims[2] + first[2];
  if constexpr (K > 0) {
    // As ffd_kernel: K-wide rows along k (contiguous control points) accumulated
    // with the (i, j) weights of the value and of d/dx, d/dy, then reduced against
    // the k basis (values, and derivatives for d/dz) once per point.
    KVec<K> val[3], gx[3], gy[3];
    for (int q = 0; q < 3; ++q) {
      val[q].setZero();
      gx[q].setZero();
      gy[q].setZero();
    }
    for (int i = 0; i < K; ++i)
      for (int j = 0; j < K; ++j) {
        const double c = N[0][i] * N[1][j], cx = dN[0][i] * N[1][j], cy = N[0][i] * dN[1][j];
        const Index row = base + i * si + j * sj;
        for (int q = 0; q < 3; ++q) {
          const KVec<K> p = kload<K>(P[q] + row);
          val[q] += c * p;
          gx[q] += cx * p;
          gy[q] += cy * p;
        }
      }
    const KVec<K> n2 = kload<K>(N[2]), d2 = kload<K>(dN[2]);
    for (int q = 0; q < 3; ++q) {
      value[q] = (n2 * val[q]).sum();
      J(q, 0) = (n2 * gx[q]).sum();
      J(q, 1) = (n2 * gy[q]).sum();
      J(q, 2) = (d2 * val[q]).sum();
    }
    return;
  }
  Vector3d val = Vector3d::Zero(), gu = Vector3d::Zero(), gv = Vector3d::Zero(), gw = Vector3d::Zero();
  for (int i = 0; i < ord[0]; ++i) {
    Vector3d c = Vector3d::Zero(), cv = Vector3d::Zero(), cw = Vector3d::Zero();
    for (int j = 0; j < ord[1]; ++j) {
      Vector3d a = Vector3d::Zero(), aw = Vector3d::Zero();
      const Index row = base + i * si + j * sj;
      for (int k = 0; k < ord[2]; ++k) {
        const Vector3d p(P[0][row + k], P[1][row + k], P[2][row + k]);
        a += N[2][k] * p;
        aw += dN[2][k] * p;
      }
      c += N[1][j] * a;
      cv += dN[1][j] * a;
      cw += N[1][j] * aw;
    }
    val += N[0][i] * c;
    gu += dN[0][i] * c;
    gv += N[0][i] * cv;
    gw += N[0][i] * cw;
  }
  value = val;
  J.col(0) = gu;
  J.col(1) = gv;
  J.col(2) = gw;
}

}  // namespace detail

/// FFD deformer of a decomposition's base: the foot points embedded in a lattice.
class MultiresFFD {
 public:
  /// @param[in] m  the decomposition (shared, not copied)
  /// @param[in] L  lattice. Foot points outside its box (they stray slightly
  ///               from the fine mesh where S(u, v) is extrapolated) follow the
  ///               boundary polynomial pieces, which the rest lattice maps onto
  ///               themselves, so the identity stays exact.
  /// @throws InvalidInputError for a bad lattice or foot points over 1000 box extents away
  MultiresFFD(std::shared_ptr<const Multires> m, Lattice L, int threads = 0)
      : m_(std::move(m)), lattice_(std::move(L)) {
    VPFFD_CHECK(m_ != nullptr, "MultiresFFD: no decomposition");
    validate_lattice(lattice_);
    tables_ = basis_tables(lattice_);
    RowMatrixX3d X(m_->n_vertices(), 3);
    for (Index i = 0; i < X.rows(); ++i) X.row(i) = m_->foot_point(i).transpose();
    embedding_ = embed(lattice_, X, OutsidePolicy::Extrapolate, threads, "foot point");
    ties_ = make_ties(lattice_);
    seams_ = FootSeams(lattice_, X);
    du_dx_ = parameter_scale(lattice_);
    if (uses_cell_runs()) runs_ = foot_runs(*m_, tables_, embedding_);
  }

  const Multires& multires() const { return *m_; }
  const Lattice& lattice() const { return lattice_; }
  /// The foot points' embedding in the lattice (span and local parameter per axis),
  /// and the lattice's per-span power forms: what a device evaluates per frame.
  const Embedding& embedding() const { return embedding_; }
  const BasisTables& tables() const { return tables_; }
  /// A periodic lattice's tie map (distinct -> extended control points) and what its
  /// seams add at each foot point: with embedding(), all a device needs for the seams.
  const Ties& ties() const { return ties_; }
  const FootSeams& seams() const { return seams_; }
  /// Control points a frame takes: the distinct ones of a periodic lattice.
  Index n_control_points() const { return ties_.n_distinct; }
  /// Bytes a frame reads per vertex: the decomposition's frame data without the
  /// foot point (replaced by its embedding): 128 - 24 + 36 = 140.
  static constexpr int frame_bytes_per_vertex = Multires::frame_bytes_per_vertex - 3 * int(sizeof(double)) +
                                                int(Embedding::bytes_per_point);

  /// D and J_D at every foot point: (#V x 3 values, #V x 9 row-major Jacobians), with
  /// the kernel deform() uses (cell runs where uses_cell_runs()).
  void foot_values_jacobians(const Eigen::Ref<const RowMatrixX3d>& P, RowMatrixX3d& values, RowMatrixXd& J,
                             int threads = 0) const {
    if (!uses_cell_runs()) return foot_values_jacobians_per_point(P, values, J, threads);
    fill_values_jacobians(P, values, J, threads, [&](auto K, const double* const* Pc, Index b, Index e, auto&& put) {
      if constexpr (decltype(K)::value > 0)
        detail::foot_runs_eval<decltype(K)::value>(tables_, runs_, du_dx_, Pc, b, e,
                                                   [&](Index u, const Vector3d& x, const Matrix3d& Ju) {
                                                     put(runs_.order[u], x, Ju);
                                                   });
    });
  }

  /// foot_values_jacobians with the per-point kernel: the reference.
  void foot_values_jacobians_per_point(const Eigen::Ref<const RowMatrixX3d>& P, RowMatrixX3d& values,
                                       RowMatrixXd& J, int threads = 0) const {
    fill_values_jacobians(P, values, J, threads, [&](auto K, const double* const* Pc, Index b, Index e, auto&& put) {
      for (Index i = b; i < e; ++i) {
        Vector3d x;
        Matrix3d Ji;
        detail::ffd_value_jacobian<decltype(K)::value>(tables_, embedding_, Pc, du_dx_, i, x, Ji);
        put(i, x, Ji);
      }
    });
  }

  /// Whether deform() runs the cell-run kernel (uniform orders 2..6) or the per-point one.
  bool uses_cell_runs() const {
    return detail::dispatch_order(tables_, [](auto K) { return decltype(K)::value > 0; });
  }

  /// Bytes per vertex held for the frames: the embedding (36), and with cell runs their
  /// sorted copy of it and of the frame data (FootRuns, 168).
  int held_bytes_per_vertex() const {
    return int(Embedding::bytes_per_point) + (uses_cell_runs() ? FootRuns::bytes_per_vertex : 0);
  }

  /// One frame with control points P (N x 3): fine vertices and approximate normals.
  /// Cell-run kernel where uses_cell_runs() (the same frame as deform_per_point to a few
  /// units in the last place of the largest term; see foot_runs.h); any thread count
  /// gives the same bits.
  MultiresFrame deform(const Eigen::Ref<const RowMatrixX3d>& P, int threads = 0) const {
    MultiresFrame out;
    out.vertices.resize(m_->n_vertices(), 3);
    out.normals.resize(m_->n_vertices(), 3);
    deform(P, out.vertices.data(), out.normals.data(), threads);
    return out;
  }
  /// deform() into the caller's #V x 3 row-major arrays X (vertices) and N (normals).
  void deform(const Eigen::Ref<const RowMatrixX3d>& P, double* X, double* N, int threads = 0) const {
    if (!uses_cell_runs()) return deform_per_point(P, X, N, threads);
    check_control_points(P);
    const PointColumns Q(expand_points(ties_, P));
    const double* const* Pc = Q.c;
    const bool seams = seams_.any();
    parallel_range(m_->n_vertices(), threads, [&](Index b, Index e) {
      detail::dispatch_order(tables_, [&](auto K) {
        if constexpr (decltype(K)::value > 0)
          detail::reconstruct_runs<decltype(K)::value>(tables_, runs_, du_dx_, Pc, X, N, b, e,
                                                       [&](Index i, Vector3d& s1, Matrix3d& J) {
                                                         if (seams) seams_.apply(i, s1, J);
                                                       });
      });
    });
  }

  /// The same frame with the per-point kernel (basis values and derivatives at each
  /// foot point): the reference of deform().
  MultiresFrame deform_per_point(const Eigen::Ref<const RowMatrixX3d>& P, int threads = 0) const {
    MultiresFrame out;
    out.vertices.resize(m_->n_vertices(), 3);
    out.normals.resize(m_->n_vertices(), 3);
    deform_per_point(P, out.vertices.data(), out.normals.data(), threads);
    return out;
  }
  /// deform_per_point() into the caller's #V x 3 row-major arrays X and N.
  void deform_per_point(const Eigen::Ref<const RowMatrixX3d>& P, double* X, double* N, int threads = 0) const {
    check_control_points(P);
    const PointColumns Q(expand_points(ties_, P));
    const double* const* Pc = Q.c;
    detail::dispatch_order(tables_, [&](auto K) {
      reconstruct(
          *m_,
          [&](Index i, const Vector3d&, const Vector3d& su, const Vector3d& sv, Vector3d& s1, Vector3d& su1,
              Vector3d& sv1) {
            Matrix3d J;
            detail::ffd_value_jacobian<decltype(K)::value>(tables_, embedding_, Pc, du_dx_, i, s1, J);
            seams_.apply(i, s1, J);
            su1 = J * su;
            sv1 = J * sv;
          },
          X, N, threads);
    });
  }

  /// @throws InvalidInputError unless P has one finite row per (distinct) control point
  void check_control_points(const Eigen::Ref<const RowMatrixX3d>& P) const {
    VPFFD_CHECK(P.rows() == n_control_points(), "MultiresFFD: ", P.rows(), " control points, the lattice has ",
                n_control_points());
    VPFFD_CHECK(P.allFinite(), "MultiresFFD: control points contain NaN or Inf");
  }

 private:
  /// The frame of both foot_values_jacobians: eval(K, Pc, b, e, put) evaluates the
  /// points of [b, e) and calls put(vertex, value, Jacobian) for each.
  template <class Eval>
  void fill_values_jacobians(const Eigen::Ref<const RowMatrixX3d>& P, RowMatrixX3d& values, RowMatrixXd& J,
                             int threads, Eval&& eval) const {
    check_control_points(P);
    const PointColumns Q(expand_points(ties_, P));
    const double* const* Pc = Q.c;
    const Index n = m_->n_vertices();
    values.resize(n, 3);
    J.resize(n, 9);
    auto put = [&](Index i, const Vector3d& value, const Matrix3d& JD) {
      Vector3d x = value;
      Matrix3d Ji = JD;
      seams_.apply(i, x, Ji);
      values.row(i) = x.transpose();
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) J(i, 3 * r + c) = Ji(r, c);
    };
    parallel_range(n, threads, [&](Index b, Index e) {
      detail::dispatch_order(tables_, [&](auto K) { eval(K, Pc, b, e, put); });
    });
  }
  std::shared_ptr<const Multires> m_;
  Lattice lattice_;
  BasisTables tables_;
  Embedding embedding_;
  Vector3d du_dx_;
  FootRuns runs_;  // empty unless uses_cell_runs()
  Ties ties_;       // distinct -> extended control points (identity without periodic axes)
  FootSeams seams_;
};

}  // namespace vpffd
