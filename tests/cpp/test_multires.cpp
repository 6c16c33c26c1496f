// Multiresolution decomposition (paper 002): exactness at rest and under rigid
// motions, the analytic foot-point Jacobian, the RBF map, and refused input.

#include <cmath>
#include <cstdio>
#include <memory>

#include "helpers.h"
#include "vpffd/multires/decomposition.h"
#include "vpffd/multires/ffd_map.h"
#include "vpffd/multires/rbf_map.h"

namespace vpffd::test {
namespace {

double diag_of(const RowMatrixX3d& V) { return (V.colwise().maxCoeff() - V.colwise().minCoeff()).norm(); }

Matrix3d rotation() {
  return (Eigen::AngleAxisd(0.7, Vector3d(1, 2, 3).normalized()) * Eigen::AngleAxisd(-1.1, Vector3d::UnitX()))
      .toRotationMatrix();
}

// Error budget of the exactness tests: every quantity is a short sum of products of
// O(1) coordinates (the affine foot point with |u|, |v| of a few units, a 64-term
// partition of unity, d N_S), each rounding by a few ulp (~1e-16) relative to the
// coordinates, i.e. about 1e-14 of the diagonal; 1e-12 leaves a factor of 100.
// Normals go through the 3x3 solves of eqs. 6-7 whose condition numbers on these
// meshes are O(10): about 1e-14 again.
constexpr double kExact = 1e-12;

TEST(Multires, IdentityLatticeReproducesMeshAndNormals) {
  const TriMesh m = bumpy(3);
  auto mr = std::make_shared<Multires>(decompose(m.V, m.F, 10.0));
  EXPECT_GT(mr->d.size(), 0u);
  double dmax = 0;
  for (double d : mr->d) dmax = std::max(dmax, std::abs(d));
  EXPECT_GT(dmax, 1e-3);  // the base is really smoother than the mesh
  const Lattice L = lattice_around(m.V, {6, 6, 6}, 3);
  const MultiresFFD ffd(mr, L);
  const MultiresFrame f = ffd.deform(rest_control_points(L));
  EXPECT_LT((f.vertices - m.V).cwiseAbs().maxCoeff(), kExact * diag_of(m.V));
  EXPECT_LT((f.normals - mr->rest_normals).cwiseAbs().maxCoeff(), kExact);
}

TEST(Multires, RigidMotionOfAllControlPoints) {
  const TriMesh m = bumpy(3);
  auto mr = std::make_shared<Multires>(decompose(m.V, m.F, 10.0));
  const Lattice L = lattice_around(m.V, {5, 6, 7}, 3);
  const Matrix3d R = rotation();
  const Vector3d t(0.3, -2.0, 1.5);
  const RowMatrixX3d P = (rest_control_points(L) * R.transpose()).rowwise() + t.transpose();
  const MultiresFrame f = MultiresFFD(mr, L).deform(P);
  const RowMatrixX3d want = (m.V * R.transpose()).rowwise() + t.transpose();
  EXPECT_LT((f.vertices - want).cwiseAbs().maxCoeff(), kExact * diag_of(m.V));
  EXPECT_LT((f.normals - mr->rest_normals * R.transpose()).cwiseAbs().maxCoeff(), kExact);
}

TEST(Multires, FootPointJacobianMatchesDifferences) {
  const TriMesh m = bumpy(2);
  auto mr = std::make_shared<Multires>(decompose(m.V, m.F, 5.0));
  const Lattice L = lattice_around(m.V, {6, 6, 6}, 3);
  const RowMatrixX3d P = twist(rest_control_points(L), 1.2, 2, 0.5 * (L.box_min + L.box_max));
  const MultiresFFD ffd(mr, L);
  RowMatrixX3d X;
  RowMatrixXd J;
  ffd.foot_values_jacobians(P, X, J);
  // Central differences of step h: truncation h^2 |D'''| / 6 (|D'''| ~ 10 for this
  // twist on a unit-size lattice: 2e-9 at h = 1e-5) plus rounding 1e-16 / h = 1e-11.
  const double h = 1e-5;
  for (Index i = 0; i < mr->n_vertices(); i += 17) {
    const Vector3d x = mr->foot_point(i);
    for (int c = 0; c < 3; ++c) {
      RowMatrixX3d Y(2, 3);
      Y.row(0) = (x + h * Vector3d::Unit(c)).transpose();
      Y.row(1) = (x - h * Vector3d::Unit(c)).transpose();
      const RowMatrixX3d D = ffd_points(L, P, Y, OutsidePolicy::Extrapolate);
      const Vector3d fd = (D.row(0) - D.row(1)).transpose() / (2 * h);
      for (int r = 0; r < 3; ++r) EXPECT_NEAR(J(i, 3 * r + c), fd[r], 1e-7) << "vertex " << i;
    }
    const RowMatrixX3d D0 = ffd_points(L, P, x.transpose(), OutsidePolicy::Extrapolate);
    EXPECT_LT((X.row(i) - D0.row(0)).norm(), 1e-14);
  }
}

TEST(Multires, ThreadCountDoesNotChangeResult) {
  const TriMesh m = bumpy(3);
  auto mr = std::make_shared<Multires>(decompose(m.V, m.F, 10.0));
  const Lattice L = lattice_around(m.V, {6, 6, 6}, 3);
  const RowMatrixX3d P = twist(rest_control_points(L), 2.0, 1, 0.5 * (L.box_min + L.box_max));
  const MultiresFFD ffd(mr, L);
  const MultiresFrame a = ffd.deform(P, 1), b = ffd.deform(P, 2);
  EXPECT_EQ((a.vertices - b.vertices).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ((a.normals - b.normals).cwiseAbs().maxCoeff(), 0.0);
}

// The cell-run kernel (multires/foot_runs.h) against the per-point one, degrees 1-5,
// a twist about each axis. Both evaluate f = sum_ijk B_i B_j B_k P_ijk with B_i(tau) =
// sum_q c_qi tau^q (the span's power form): the per-point kernel by Horner on each B_i
// (error gamma_2K relative to beta_i = sum_q |c_qi| |tau|^q) and then tensor sums
// (gamma_{3K+3}); the run kernel by three staged sums of K terms for the cell's
// power coefficients (gamma_{3K+3}) and nested Horner over them (gamma_{6K}). With
// A_a = max over spans of sum_i beta_i (tau_max), both are within gamma_{9K+3} A_u A_v
// A_w max|P| of f, so they differ by at most twice that. A column a of J replaces
// beta by sum_q q |c_qi| |tau|^(q-1) on axis a (A'_a) and is scaled by d tau / dx
// (one more rounding; the derivative's Horner recurrence doubles the run kernel's
// count): 2 gamma_{12K} A'_a A_b A_c max|P| max(d tau / dx). These are worst cases
// (for cubics A = 16/3, so about 1.3e-12 of max|P|); the largest differences seen
// are printed.
TEST(Multires, CellRunKernelEqualsPerPointKernel) {
  const TriMesh m = bumpy(6);  // 40962 vertices: above kParallelMin, so threads split the runs
  auto mr = std::make_shared<Multires>(decompose(m.V, m.F, 10.0));
  const double u = std::ldexp(1.0, -53);
  auto gamma = [&](int n) { return n * u / (1 - n * u); };
  for (int degree = 1; degree <= 5; ++degree) {
    const Lattice L = lattice_around(m.V, {6, 7, 8}, degree);
    const MultiresFFD ffd(mr, L);
    ASSERT_TRUE(ffd.uses_cell_runs());
    const BasisTables& T = ffd.tables();
    const Embedding& E = ffd.embedding();
    const int K = degree + 1;
    double A[3], A1[3], smax[3];
    const Vector3d du_dx = parameter_scale(L);
    for (int a = 0; a < 3; ++a) {
      double tmax = 1;
      for (double t : E.tau[a]) tmax = std::max(tmax, std::abs(t));
      A[a] = A1[a] = smax[a] = 0;
      const SpanPolynomials& sp = T.poly[a];
      for (int s = sp.first_span; s < sp.first_span + sp.n_spans; ++s) {
        const double* c = sp.span_coef(s);
        double sum = 0, sum1 = 0;
        for (int q = 0; q < K; ++q)
          for (int i = 0; i < K; ++i) {
            sum += std::abs(c[q * K + i]) * std::pow(tmax, q);
            if (q > 0) sum1 += q * std::abs(c[q * K + i]) * std::pow(tmax, q - 1);
          }
        A[a] = std::max(A[a], sum);
        A1[a] = std::max(A1[a], sum1);
        smax[a] = std::max(smax[a], sp.inv_width[s - sp.first_span] * du_dx[a]);
      }
    }
    for (int axis = 0; axis < 3; ++axis) {
      const RowMatrixX3d P = twist(rest_control_points(L), 1.0, axis, 0.5 * (L.box_min + L.box_max));
      const double pmax = P.cwiseAbs().maxCoeff();
      RowMatrixX3d X0, X, Xt;
      RowMatrixXd J0, J, Jt;
      ffd.foot_values_jacobians_per_point(P, X0, J0, 1);
      ffd.foot_values_jacobians(P, X, J, 1);
      const double eV = 2 * gamma(9 * K + 3) * A[0] * A[1] * A[2] * pmax;
      EXPECT_LE((X - X0).cwiseAbs().maxCoeff(), eV) << "degree " << degree << " axis " << axis;
      for (int c = 0; c < 3; ++c) {
        const double eJ = 2 * gamma(12 * K) * A1[c] * A[(c + 1) % 3] * A[(c + 2) % 3] * pmax * smax[c];
        for (int r = 0; r < 3; ++r)
          EXPECT_LE((J.col(3 * r + c) - J0.col(3 * r + c)).cwiseAbs().maxCoeff(), eJ)
              << "degree " << degree << " axis " << axis << " J(" << r << ", " << c << ")";
      }
      std::printf("  degree %d twist about %d: values differ by %.1e of max|P| (bound %.1e), Jacobians by %.1e\n",
                  degree, axis, (X - X0).cwiseAbs().maxCoeff() / pmax, eV / pmax,
                  (J - J0).cwiseAbs().maxCoeff() / (pmax * std::max({smax[0], smax[1], smax[2]})));
      // The frame is the reconstruction of these values and Jacobians (the same
      // formulas, compiled in another place: the compiler may fuse other multiply-adds,
      // so each operation may round differently, by u of its terms; e = 16 u |terms|
      // per step covers both sides), and neither depends on the thread count.
      const MultiresFrame f = ffd.deform(P, 1);
      const double w = 16 * u;
      for (Index i = 0; i < mr->n_vertices(); ++i) {
        Matrix3d Ji;
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) Ji(r, c) = J(i, 3 * r + c);
        const Vector3d su = mr->tangent_u(i), sv = mr->tangent_v(i), su1 = Ji * su, sv1 = Ji * sv;
        Vector3d p, n;
        reconstruct_vertex(X.row(i).transpose(), su1, sv1, mr->d[i], mr->coefficients(i), p, n);
        const double e_su = w * (Ji.cwiseAbs() * su.cwiseAbs()).norm(), e_sv = w * (Ji.cwiseAbs() * sv.cwiseAbs()).norm();
        const Vector3d cr = su1.cross(sv1), ns = cr.normalized();
        const double e_c = e_su * sv1.norm() + su1.norm() * e_sv + e_su * e_sv + w * su1.norm() * sv1.norm();
        const double e_N = 2 * e_c / cr.norm() + w, ad = std::abs(mr->d[i]);
        const double e_p = ad * e_N + w * (X.row(i).norm() + ad);
        const NormalCoefficients k = mr->coefficients(i);
        Vector3d fw[2];
        double ef[2];
        for (int j = 0; j < 2; ++j) {
          const double a = std::abs(k[3 * j]), b = std::abs(k[3 * j + 1]), g = std::abs(k[3 * j + 2]);
          fw[j] = k[3 * j] * su1 + k[3 * j + 1] * sv1 + k[3 * j + 2] * ns;
          ef[j] = a * e_su + b * e_sv + g * e_N + w * (a * su1.norm() + b * sv1.norm() + g);
        }
        const double e_n = ef[0] * fw[1].norm() + fw[0].norm() * ef[1] + ef[0] * ef[1] + w * fw[0].norm() * fw[1].norm();
        // A unit vector's change: at most 2 |dn| / |n| plus the normalisation's rounding.
        const double e_unit = 2 * e_n / fw[0].cross(fw[1]).norm() + w;
        ASSERT_LE((p - f.vertices.row(i).transpose()).norm(), e_p) << "vertex " << i;
        ASSERT_LE((n - f.normals.row(i).transpose()).norm(), e_unit) << "vertex " << i;
      }
      for (int threads : {2, 3}) {
        ffd.foot_values_jacobians(P, Xt, Jt, threads);
        EXPECT_TRUE(Xt == X && Jt == J) << threads << " threads";
        const MultiresFrame ft = ffd.deform(P, threads);
        EXPECT_TRUE(ft.vertices == f.vertices && ft.normals == f.normals) << threads << " threads";
      }
    }
  }
}

// Mixed orders have no cell-run kernel: deform() is the per-point frame.
TEST(Multires, MixedOrdersUseThePerPointKernel) {
  const TriMesh m = bumpy(3);
  auto mr = std::make_shared<Multires>(decompose(m.V, m.F, 10.0));
  Lattice L = lattice_around(m.V, {6, 6, 6}, 3);
  const Lattice L2 = lattice_around(m.V, {6, 6, 6}, 2);
  L.degree[1] = 2;
  L.knots[1] = L2.knots[1];
  const MultiresFFD ffd(mr, L);
  EXPECT_FALSE(ffd.uses_cell_runs());
  const RowMatrixX3d P = twist(rest_control_points(L), 1.0, 2, 0.5 * (L.box_min + L.box_max));
  const MultiresFrame a = ffd.deform(P), b = ffd.deform_per_point(P);
  EXPECT_TRUE(a.vertices == b.vertices && a.normals == b.normals);
}

TEST(Multires, RbfInterpolatesAndIsIdentityForUnmovedHandles) {
  const TriMesh m = bumpy(2);
  const Multires mr = decompose(m.V, m.F, 10.0);
  RowMatrixX3d H(12, 3);
  for (Index j = 0; j < H.rows(); ++j) H.row(j) = m.V.row(j * 13);
  const RbfMap rbf(H);
  // Unmoved handles: the polynomial part reproduces the identity; the kernel weights
  // vanish to the solve's rounding (cond of a 16x16 normalised system, ~1e6, times
  // 1e-16, further reduced by the refinement step).
  const MultiresFrame id = rbf_deform(mr, rbf, rbf.solve(H));
  EXPECT_LT((id.vertices - m.V).cwiseAbs().maxCoeff(), kExact * diag_of(m.V));
  EXPECT_LT((id.normals - mr.rest_normals).cwiseAbs().maxCoeff(), kExact);
  RowMatrixX3d T = H;
  T.row(0) += Vector3d(0.2, 0.1, -0.3).transpose();
  T.row(5) += Vector3d(-0.1, 0.25, 0.0).transpose();
  const RbfWeights W = rbf.solve(T);
  EXPECT_LT((rbf.map(W, H) - T).cwiseAbs().maxCoeff(), kExact * diag_of(m.V));
  // Analytic Jacobian against central differences (truncation h^2 |r'''| with
  // |r'''| ~ 6 |w| / |x - c| stays below 1e-8 at h = 1e-5 away from the centres).
  const Vector3d x(0.13, -0.41, 0.27);
  Vector3d v;
  Matrix3d J;
  rbf.eval(W, x, v, J);
  const double h = 1e-5;
  for (int c = 0; c < 3; ++c) {
    Vector3d a, b;
    Matrix3d dummy;
    rbf.eval(W, x + h * Vector3d::Unit(c), a, dummy);
    rbf.eval(W, x - h * Vector3d::Unit(c), b, dummy);
    EXPECT_LT((J.col(c) - (a - b) / (2 * h)).norm(), 1e-7);
  }
}

TEST(Multires, RbfRefusesSingularHandleSets) {
  RowMatrixX3d three(3, 3);
  three << 0, 0, 0, 1, 0, 0, 0, 1, 0;
  EXPECT_THROW(RbfMap{three}, InvalidInputError);
  RowMatrixX3d planar(5, 3);
  planar << 0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0.5, 0.3, 0;
  try {
    RbfMap r(planar);
    FAIL() << "coplanar handles accepted";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("plane"), std::string::npos) << e.what();
  }
  RowMatrixX3d dup(5, 3);
  dup << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 0, 0;
  try {
    RbfMap r(dup);
    FAIL() << "duplicate handles accepted";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("same point"), std::string::npos) << e.what();
  }
  RowMatrixX3d ok(4, 3);
  ok << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  const RbfMap r(ok);
  EXPECT_THROW(r.solve(RowMatrixX3d::Zero(3, 3)), InvalidInputError);
}

TEST(Multires, RefusesBadSmoothingAndLooseVertices) {
  const TriMesh m = bumpy(1);
  EXPECT_THROW(decompose(m.V, m.F, 0.0), InvalidInputError);
  EXPECT_THROW(decompose(m.V, m.F, -1.0), InvalidInputError);
  EXPECT_THROW(decompose(m.V, m.F, std::nan("")), InvalidInputError);
  RowMatrixX3d V(m.V.rows() + 1, 3);
  V << m.V, RowMatrixX3d::Zero(1, 3);
  try {
    decompose(V, m.F, 5.0);
    FAIL() << "a vertex in no triangle was accepted";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find(std::to_string(m.V.rows())), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace vpffd::test
