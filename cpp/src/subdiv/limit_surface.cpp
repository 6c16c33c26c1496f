// The limit surface through Bfr: Far builds the topology, a RefinerSurfaceFactory
// makes one Bfr::Surface per control face (with the approximation level raised around
// irregular features), and we keep each surface with its patch points.

#include "limit_surface.h"

#include <algorithm>

#include <opensubdiv/bfr/refinerSurfaceFactory.h>
#include <opensubdiv/bfr/surface.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

#include "vpffd/core/check.h"

namespace vpffd::subdiv {

namespace osd = OpenSubdiv;

struct LimitSurface::Impl {
  std::unique_ptr<osd::Far::TopologyRefiner> refiner;
  std::vector<osd::Bfr::Surface<double>> surfaces;  // one per control face
  std::vector<std::vector<double>> patch_points;     // one array per face, 3 per point
  // Normalised sub-face (Ptex) coordinates -> the face's (u, v): uv = origin + scale * st.
  std::vector<double> origin_u, origin_v, scale;
};

LimitSurface::LimitSurface(SubdivScheme scheme, Index n_control, const std::vector<std::int32_t>& face_sizes,
                           const std::vector<std::int32_t>& face_vertices, int approx_level)
    : impl_(std::make_unique<Impl>()) {
  using Factory = osd::Far::TopologyRefinerFactory<osd::Far::TopologyDescriptor>;
  osd::Far::TopologyDescriptor desc;
  desc.numVertices = int(n_control);
  desc.numFaces = int(face_sizes.size());
  desc.numVertsPerFace = face_sizes.data();
  desc.vertIndicesPerFace = face_vertices.data();
  osd::Sdc::Options sdc;
  // Boundaries (an open control mesh) interpolate their edges and corners: the
  // limit surface ends at the control mesh's boundary curve.
  sdc.SetVtxBoundaryInterpolation(osd::Sdc::Options::VTX_BOUNDARY_EDGE_AND_CORNER);
  const osd::Sdc::SchemeType type = scheme == SubdivScheme::Loop ? osd::Sdc::SCHEME_LOOP : osd::Sdc::SCHEME_CATMARK;
  impl_->refiner.reset(Factory::Create(desc, Factory::Options(type, sdc)));
  VPFFD_CHECK(impl_->refiner != nullptr, "SubdivisionMultires: OpenSubdiv refused the control mesh's topology");

  osd::Bfr::SurfaceFactory::Options opts;
  opts.SetApproxLevelSmooth(approx_level).SetApproxLevelSharp(approx_level);
  // The cache shares irregular patches between faces; the factory is used here,
  // on one thread, only.
  osd::Bfr::RefinerSurfaceFactory<> factory(*impl_->refiner, opts);
  const int nf = desc.numFaces;
  impl_->surfaces.resize(nf);
  impl_->patch_points.resize(nf);
  triangular_ = scheme == SubdivScheme::Loop;
  for (int f = 0; f < nf; ++f) {
    VPFFD_CHECK(factory.InitVertexSurface(f, &impl_->surfaces[f]), "SubdivisionMultires: control face ", f,
                " has no limit surface (OpenSubdiv)");
    const osd::Bfr::Parameterization param = impl_->surfaces[f].GetParameterization();
    const int subs = param.HasSubFaces() ? param.GetFaceSize() : 1;
    for (int s = 0; s < subs; ++s) {
      patch_face_.push_back(f);
      patch_sub_.push_back(param.HasSubFaces() ? s : -1);
    }
  }
  // One affine map per patch from normalised sub-face coordinates to the face's.
  const int np = int(patch_face_.size());
  impl_->origin_u.assign(np, 0);
  impl_->origin_v.assign(np, 0);
  impl_->scale.assign(np, 1);
  for (int k = 0; k < np; ++k) {
    if (patch_sub_[k] < 0) continue;
    const osd::Bfr::Parameterization param = impl_->surfaces[patch_face_[k]].GetParameterization();
    const double st0[2] = {0, 0}, st1[2] = {1, 0};
    double uv0[2], uv1[2];
    param.ConvertNormalizedSubFaceToCoord(patch_sub_[k], st0, uv0);
    param.ConvertNormalizedSubFaceToCoord(patch_sub_[k], st1, uv1);
    impl_->origin_u[k] = uv0[0];
    impl_->origin_v[k] = uv0[1];
    impl_->scale[k] = uv1[0] - uv0[0];
  }
}

LimitSurface::~LimitSurface() = default;

void LimitSurface::set_points(const RowMatrixX3d& C) {
  VPFFD_CHECK(C.rows() == impl_->refiner->GetLevel(0).GetNumVertices(), "LimitSurface: expected ",
              impl_->refiner->GetLevel(0).GetNumVertices(), " control points, got ", C.rows());
  const osd::Bfr::Surface<double>::PointDescriptor desc(3);
  for (size_t f = 0; f < impl_->surfaces.size(); ++f) {
    const auto& s = impl_->surfaces[f];
    impl_->patch_points[f].resize(size_t(s.GetNumPatchPoints()) * 3);
    s.PreparePatchPoints(C.data(), desc, impl_->patch_points[f].data(), desc);
  }
}

namespace {

// First derivatives only, in the face's (u, v).
void evaluate_first(const osd::Bfr::Surface<double>& s, const std::vector<double>& pp, const double uv[2], double* P,
                    double* du, double* dv) {
  s.Evaluate(uv, pp.data(), osd::Bfr::Surface<double>::PointDescriptor(3), P, du, dv);
}

}  // namespace

LimitPoint LimitSurface::evaluate(int patch, double u, double v) const {
  const int f = patch_face_[patch];
  const double k = impl_->scale[patch];
  const auto& s = impl_->surfaces[f];
  const auto& pp = impl_->patch_points[f];
  const double uv[2] = {impl_->origin_u[patch] + k * u, impl_->origin_v[patch] + k * v};
  LimitPoint r;
  evaluate_first(s, pp, uv, r.p.data(), r.du.data(), r.dv.data());
  // Second derivatives by forward differences of the first: Bfr's own second
  // derivatives on irregular Loop patches are off by ~100 % (checked against
  // differences of its first derivatives), which stalls Newton. h = 1e-7 leaves a
  // relative error of ~1e-7 (truncation) + 1e-9 (rounding): Newton then converges at
  // that rate per step. The differences are taken at a base point moved inside the
  // domain by at most h where (u, v) is on its far edges, so that no evaluation
  // leaves the patch (Bfr does not define one outside).
  constexpr double h = 1e-7;
  double ub = u, vb = v;
  if (triangular_) {
    if (ub + vb > 1 - h) {
      const double f = (1 - h) / (ub + vb);
      ub *= f;
      vb *= f;
    }
  } else {
    ub = std::min(ub, 1 - h);
    vb = std::min(vb, 1 - h);
  }
  Vector3d p0, du0 = r.du, dv0 = r.dv;
  if (ub != u || vb != v) {
    const double uv0[2] = {impl_->origin_u[patch] + k * ub, impl_->origin_v[patch] + k * vb};
    evaluate_first(s, pp, uv0, p0.data(), du0.data(), dv0.data());
  }
  Vector3d p1, du1, dv1, p2, du2, dv2;
  const double uv1[2] = {impl_->origin_u[patch] + k * (ub + h), impl_->origin_v[patch] + k * vb};
  const double uv2[2] = {impl_->origin_u[patch] + k * ub, impl_->origin_v[patch] + k * (vb + h)};
  evaluate_first(s, pp, uv1, p1.data(), du1.data(), dv1.data());
  evaluate_first(s, pp, uv2, p2.data(), du2.data(), dv2.data());
  // Chain rule of uv = origin + k st: first derivatives scale by k, second by k^2;
  // the differences are over a step of h in st, so they already carry one k.
  r.du *= k;
  r.dv *= k;
  r.duu = (du1 - du0) * (k / h);
  r.duv = 0.5 * ((dv1 - dv0) + (du2 - du0)) * (k / h);
  r.dvv = (dv2 - dv0) * (k / h);
  return r;
}

void LimitSurface::stencil(int patch, double u, double v, std::vector<std::int32_t>& idx, std::vector<double>& w,
                           std::vector<double>& wu, std::vector<double>& wv) const {
  const int f = patch_face_[patch];
  const auto& s = impl_->surfaces[f];
  const double k = impl_->scale[patch];
  const double uv[2] = {impl_->origin_u[patch] + k * u, impl_->origin_v[patch] + k * v};
  const int n = s.GetNumControlPoints();
  const size_t at = idx.size();
  idx.resize(at + n);
  w.resize(at + n);
  wu.resize(at + n);
  wv.resize(at + n);
  s.GetControlPointIndices(idx.data() + at);
  s.EvaluateStencil(uv, w.data() + at, wu.data() + at, wv.data() + at);
  for (int j = 0; j < n; ++j) {
    wu[at + j] *= k;
    wv[at + j] *= k;
  }
}

}  // namespace vpffd::subdiv
