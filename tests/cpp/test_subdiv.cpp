// Displaced subdivision surfaces (vpffd::subdiv, paper 002 §5): limit stencils
// against OpenSubdiv's Far limit stencils (an independent evaluation path), partition
// of unity, exact foot points, identity and affine group frames.
#ifdef VPFFD_HAS_OPENSUBDIV

#include <cmath>
#include <memory>
#include <random>

#include <opensubdiv/far/stencilTable.h>
#include <opensubdiv/far/stencilTableFactory.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

#include "helpers.h"
#include "vpffd/multires/fitting.h"
#include "vpffd/subdiv/subdivision_frame.h"
#include "vpffd/subdiv/subdivision_multires.h"

namespace vpffd::test_subdiv {

namespace osd = OpenSubdiv;

/// A bumpy icosphere (2,562 vertices) over a decimated control mesh of ~150.
inline const SubdivisionMultires& decomposition(SubdivScheme scheme) {
  static const TriMesh fine = test::bumpy(4);
  static std::unique_ptr<SubdivisionMultires> m[2];
  const int k = scheme == SubdivScheme::Loop ? 0 : 1;
  if (!m[k]) {
    SubdivOptions o;
    o.scheme = scheme;
    m[k] = std::make_unique<SubdivisionMultires>(decompose_subdivision(fine.V, fine.F, Index(150), o));
  }
  return *m[k];
}

/// Far's limit stencils (adaptive refinement to `level`, the same approximation
/// level as Bfr's) at each vertex's (patch = Ptex face, u, v), dense per row.
inline void far_stencils(const SubdivisionMultires& m, int level, Eigen::MatrixXd& W, Eigen::MatrixXd& Wu,
                         Eigen::MatrixXd& Wv) {
  using Factory = osd::Far::TopologyRefinerFactory<osd::Far::TopologyDescriptor>;
  osd::Far::TopologyDescriptor desc;
  desc.numVertices = int(m.n_control());
  desc.numFaces = int(m.control_face_sizes.size());
  desc.numVertsPerFace = m.control_face_sizes.data();
  desc.vertIndicesPerFace = m.control_faces.data();
  osd::Sdc::Options sdc;
  sdc.SetVtxBoundaryInterpolation(osd::Sdc::Options::VTX_BOUNDARY_EDGE_AND_CORNER);
  const auto type = m.scheme == SubdivScheme::Loop ? osd::Sdc::SCHEME_LOOP : osd::Sdc::SCHEME_CATMARK;
  std::unique_ptr<osd::Far::TopologyRefiner> refiner(Factory::Create(desc, Factory::Options(type, sdc)));
  ASSERT_TRUE(refiner);
  refiner->RefineAdaptive(osd::Far::TopologyRefiner::AdaptiveOptions(level));
  using LSF = osd::Far::LimitStencilTableFactoryReal<double>;
  LSF::LocationArrayVec locs;
  const Index n = m.n_vertices();
  for (Index i = 0; i < n; ++i) {
    LSF::LocationArray a;
    a.ptexIdx = m.patch[i];
    a.numLocations = 1;
    a.s = &m.u[i];
    a.t = &m.v[i];
    locs.push_back(a);
  }
  std::unique_ptr<const osd::Far::LimitStencilTableReal<double>> table(LSF::Create(*refiner, locs));
  ASSERT_TRUE(table);
  ASSERT_EQ(table->GetNumStencils(), n);
  W.setZero(n, m.n_control());
  Wu.setZero(n, m.n_control());
  Wv.setZero(n, m.n_control());
  for (Index i = 0; i < n; ++i) {
    const auto s = table->GetLimitStencil(osd::Far::Index(i));
    for (int k = 0; k < s.GetSize(); ++k) {
      W(i, s.GetVertexIndices()[k]) += s.GetWeights()[k];
      Wu(i, s.GetVertexIndices()[k]) += s.GetDuWeights()[k];
      Wv(i, s.GetVertexIndices()[k]) += s.GetDvWeights()[k];
    }
  }
}

inline void our_stencils(const SubdivisionMultires& m, Eigen::MatrixXd& W, Eigen::MatrixXd& Wu, Eigen::MatrixXd& Wv) {
  const LimitStencils& st = m.stencils;
  W.setZero(m.n_vertices(), m.n_control());
  Wu = W;
  Wv = W;
  for (Index i = 0; i < m.n_vertices(); ++i)
    for (std::int64_t k = st.indptr[i]; k < st.indptr[i + 1]; ++k) {
      W(i, st.indices[k]) += st.w[k];
      Wu(i, st.indices[k]) += st.wu[k];
      Wv(i, st.indices[k]) += st.wv[k];
    }
}

class Subdiv : public ::testing::TestWithParam<SubdivScheme> {};

TEST_P(Subdiv, StencilsArePartitionsOfUnity) {
  // Weights are O(1) numbers summed in ~12-40 terms: rounding ~1e-15.
  const SubdivisionMultires& m = decomposition(GetParam());
  const LimitStencils& st = m.stencils;
  for (Index i = 0; i < m.n_vertices(); ++i) {
    double s = 0, su = 0, sv = 0;
    for (std::int64_t k = st.indptr[i]; k < st.indptr[i + 1]; ++k) s += st.w[k], su += st.wu[k], sv += st.wv[k];
    ASSERT_NEAR(s, 1.0, 1e-12) << "vertex " << i;
    ASSERT_NEAR(su, 0.0, 1e-12) << "vertex " << i;
    ASSERT_NEAR(sv, 0.0, 1e-12) << "vertex " << i;
  }
}

TEST_P(Subdiv, StencilsAgreeWithFarLimitStencils) {
  // Far (adaptive patch table + limit stencil factory) and Bfr build the same
  // piecewise polynomial surface at equal approximation levels, so only rounding
  // differs (~1e-15 per weight); weights of derivatives are O(1..10).
  const SubdivisionMultires& m = decomposition(GetParam());
  Eigen::MatrixXd W, Wu, Wv, Fw, Fu, Fv;
  our_stencils(m, W, Wu, Wv);
  far_stencils(m, 6, Fw, Fu, Fv);
  EXPECT_LT((W - Fw).cwiseAbs().maxCoeff(), 1e-12);
  // Far differentiates a sub-face of a non-quad face (every Catmull-Clark triangle
  // here) in the face's parameterisation, where a sub-face spans 1/2; ours are per
  // unit of the Ptex (u, v) that both take as input, hence half of Far's.
  const double k = m.scheme == SubdivScheme::CatmullClark ? 0.5 : 1.0;
  EXPECT_LT((Wu - k * Fu).cwiseAbs().maxCoeff(), 1e-11);
  EXPECT_LT((Wv - k * Fv).cwiseAbs().maxCoeff(), 1e-11);
}

TEST_P(Subdiv, FootPointsAreExact) {
  const SubdivisionMultires& m = decomposition(GetParam());
  EXPECT_TRUE(m.unresolved.empty());
  const double tol = kFootPointTolerance * m.diagonal;
  for (Index i = 0; i < m.n_vertices(); ++i) {
    Vector3d s, su, sv;
    evaluate_stencils(m.stencils, m.control_points.data(), i, s, su, sv);
    ASSERT_LE(tangential_residual(m.fine.row(i).transpose(), s, su.cross(sv).normalized()), tol) << "vertex " << i;
  }
}

TEST_P(Subdiv, IdentityFrameReproducesTheMesh) {
  // p' - p is the tangential part of p - S (<= 1e-9 of the diagonal) plus rounding.
  const SubdivisionMultires& m = decomposition(GetParam());
  const SubdivFrame f = deform_subdivision(m, m.control_points);
  EXPECT_LE((f.vertices - m.fine).cwiseAbs().maxCoeff(), kFootPointTolerance * m.diagonal);
  // At rest the coefficients rebuild the area-weighted normal exactly (to rounding).
  EXPECT_LE((f.normals - m.rest_normals).cwiseAbs().maxCoeff(), 1e-12);
}

TEST_P(Subdiv, AffineGroupEqualsTheFullFrame) {
  const SubdivisionMultires& m = decomposition(GetParam());
  const std::vector<std::int32_t> group = {3, 17, 40, 41};
  const AffineGroup g = make_affine_group(m, m.control_points, group);
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T.topLeftCorner<3, 3>() = Eigen::AngleAxisd(0.3, Vector3d(1, 2, 3).normalized()).toRotationMatrix() * 1.2;
  T.topRightCorner<3, 1>() = Vector3d(0.1, -0.05, 0.2);
  RowMatrixX3d C = m.control_points;
  for (std::int32_t j : group) C.row(j) = (T.topLeftCorner<3, 3>() * C.row(j).transpose() + T.topRightCorner<3, 1>());
  const SubdivFrame a = deform_subdivision(m, C), b = deform_affine_group(m, g, T);
  // Two summation orders of the same ~12-40 products: rounding, relative to the size.
  EXPECT_LE((a.vertices - b.vertices).cwiseAbs().maxCoeff(), 1e-12 * m.diagonal);
  EXPECT_LE((a.normals - b.normals).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_THROW(make_affine_group(m, m.control_points, {3, 3}), InvalidInputError);
  EXPECT_THROW(make_affine_group(m, m.control_points, {int(m.n_control())}), InvalidInputError);
}

TEST_P(Subdiv, BadControlPointsAreRefused) {
  const SubdivisionMultires& m = decomposition(GetParam());
  RowMatrixX3d C = m.control_points;
  EXPECT_THROW(deform_subdivision(m, C.topRows(C.rows() - 1)), InvalidInputError);
  C(5, 1) = std::nan("");
  EXPECT_THROW(deform_subdivision(m, C), InvalidInputError);
}

INSTANTIATE_TEST_SUITE_P(Schemes, Subdiv, ::testing::Values(SubdivScheme::Loop, SubdivScheme::CatmullClark));

TEST(SubdivInput, LoopRefusesQuadsAndBadControlMeshes) {
  const TriMesh fine = test::bumpy(2);
  const TriMesh box = box_mesh(1);  // triangulated cube: 8 points
  std::vector<std::int32_t> quad_sizes = {4};
  std::vector<std::int32_t> quad = {0, 1, 2, 3};
  SubdivOptions o;
  EXPECT_THROW(decompose_subdivision(fine.V, fine.F, box.V, quad_sizes, quad, o), InvalidInputError);
  std::vector<std::int32_t> sizes(box.F.rows(), 3), verts(box.F.data(), box.F.data() + box.F.size());
  verts[0] = 99;  // out of range
  EXPECT_THROW(decompose_subdivision(fine.V, fine.F, box.V, sizes, verts, o), InvalidInputError);
}

}  // namespace vpffd::test_subdiv

#endif  // VPFFD_HAS_OPENSUBDIV
