// The decomposition of paper 002 §5 (and the fitting of §4.1): foot points on the
// limit surface of the control mesh, alternating with a least-squares fit of the
// control points (multires/fitting.h) at fixed foot parameters; then per fine vertex
// the limit stencils, d and the six normal coefficients at its exact foot point.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <sstream>
#include <utility>

#include "foot_search.h"
#include "limit_surface.h"
#include "vpffd/core/check.h"
#include "vpffd/core/parallel.h"
#include "vpffd/ffd/normals.h"
#include "vpffd/mesh/validate.h"
#include "vpffd/multires/fitting.h"
#include "vpffd/multires/normal_coefficients.h"
#include "vpffd/subdiv/subdivision_multires.h"

namespace vpffd {

namespace {

using subdiv::FootParam;
using subdiv::LimitSurface;

void check_options(const SubdivOptions& o) {
  VPFFD_CHECK(std::isfinite(o.fairness) && o.fairness >= 0, "SubdivisionMultires: fairness must be >= 0, got ",
              o.fairness);
  VPFFD_CHECK(o.iterations >= 0 && o.iterations <= 100, "SubdivisionMultires: iterations must be in 0..100, got ",
              o.iterations);
  VPFFD_CHECK(o.approx_level >= 1 && o.approx_level <= 10, "SubdivisionMultires: approx_level must be in 1..10, got ",
              o.approx_level);
  VPFFD_CHECK(o.max_unresolved >= 0, "SubdivisionMultires: max_unresolved must be >= 0, got ", o.max_unresolved);
}

void check_fine_mesh(const Eigen::Ref<const RowMatrixX3d>& V, const Eigen::Ref<const RowMatrixX3i>& F) {
  validate_mesh(V, F, "SubdivisionMultires");
  const EdgeReport r = edge_report(F);
  VPFFD_CHECK(r.nonmanifold_edges == 0, "SubdivisionMultires: the fine mesh has ", r.nonmanifold_edges,
              " non-manifold edges (shared by more than two faces); a displaced surface needs a manifold mesh");
  VPFFD_CHECK(r.misoriented_edges == 0, "SubdivisionMultires: the fine mesh is inconsistently oriented (",
              r.misoriented_edges, " edges used twice in the same direction)");
}

/// Checks the control polygons: sizes for the scheme, indices, every control point
/// used, and every edge in at most two faces, once in each direction.
void check_control_mesh(SubdivScheme scheme, Index n, const std::vector<std::int32_t>& sizes,
                        const std::vector<std::int32_t>& verts) {
  VPFFD_CHECK(n >= 3 && !sizes.empty(), "SubdivisionMultires: the control mesh is empty");
  std::int64_t total = 0;
  for (size_t f = 0; f < sizes.size(); ++f) {
    const int s = sizes[f];
    if (scheme == SubdivScheme::Loop)
      VPFFD_CHECK(s == 3, "SubdivisionMultires: Loop subdivision needs triangles, but control face ", f, " has ", s,
                  " vertices (use scheme='catmark' for quads)");
    else
      VPFFD_CHECK(s == 3 || s == 4, "SubdivisionMultires: control face ", f, " has ", s,
                  " vertices; Catmull-Clark here takes triangles and quads");
    total += s;
  }
  VPFFD_CHECK(total == std::int64_t(verts.size()), "SubdivisionMultires: the control faces list ", verts.size(),
              " vertices, their sizes sum to ", total);
  std::vector<char> used(n, 0);
  std::map<std::pair<std::int32_t, std::int32_t>, int> directed;
  std::int64_t at = 0;
  for (size_t f = 0; f < sizes.size(); ++f) {
    for (int c = 0; c < sizes[f]; ++c) {
      const std::int32_t a = verts[at + c], b = verts[at + (c + 1) % sizes[f]];
      VPFFD_CHECK(a >= 0 && a < n, "SubdivisionMultires: control face ", f, " refers to vertex ", a,
                  " outside [0, ", n, ")");
      VPFFD_CHECK(a != b, "SubdivisionMultires: control face ", f, " repeats vertex ", a);
      used[a] = 1;
      const int uses = ++directed[std::make_pair(a, b)];
      VPFFD_CHECK(uses == 1, "SubdivisionMultires: the control edge (", a, ", ", b,
                  ") is used twice in one direction: the control mesh is non-manifold or inconsistently oriented");
    }
    at += sizes[f];
  }
  for (Index j = 0; j < n; ++j)
    VPFFD_CHECK(used[j], "SubdivisionMultires: control point ", j, " is in no control face");
}

/// K = L^T L of the uniform Laplacian of the control polygons' edges.
Eigen::SparseMatrix<double> fairness_form(Index n, const std::vector<std::int32_t>& sizes,
                                          const std::vector<std::int32_t>& verts) {
  std::vector<std::pair<std::int32_t, std::int32_t>> edges;
  std::int64_t at = 0;
  for (int s : sizes) {
    for (int c = 0; c < s; ++c) {
      const std::int32_t a = verts[at + c], b = verts[at + (c + 1) % s];
      edges.emplace_back(std::min(a, b), std::max(a, b));
    }
    at += s;
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  std::vector<double> degree(n, 0);
  for (const auto& [a, b] : edges) degree[a] += 1, degree[b] += 1;
  std::vector<Eigen::Triplet<double>> t;
  for (Index j = 0; j < n; ++j) t.emplace_back(int(j), int(j), 1.0);
  for (const auto& [a, b] : edges) {
    t.emplace_back(a, b, -1.0 / degree[a]);
    t.emplace_back(b, a, -1.0 / degree[b]);
  }
  Eigen::SparseMatrix<double> L(n, n);
  L.setFromTriplets(t.begin(), t.end());
  return Eigen::SparseMatrix<double>(L.transpose() * L);
}

/// Stencils at the foot points (duplicate control indices merged, sorted).
LimitStencils build_stencils(const LimitSurface& s, const std::vector<FootParam>& fp) {
  LimitStencils st;
  st.indptr.assign(fp.size() + 1, 0);
  std::vector<std::int32_t> idx;
  std::vector<double> w, wu, wv;
  std::vector<std::pair<std::int32_t, int>> order;
  for (size_t i = 0; i < fp.size(); ++i) {
    idx.clear(), w.clear(), wu.clear(), wv.clear();
    s.stencil(fp[i].patch, fp[i].u, fp[i].v, idx, w, wu, wv);
    order.clear();
    for (size_t k = 0; k < idx.size(); ++k) order.emplace_back(idx[k], int(k));
    std::sort(order.begin(), order.end());
    for (size_t k = 0; k < order.size(); ++k) {
      const int q = order[k].second;
      if (k > 0 && order[k].first == order[k - 1].first) {
        st.w.back() += w[q];
        st.wu.back() += wu[q];
        st.wv.back() += wv[q];
      } else {
        st.indices.push_back(order[k].first);
        st.w.push_back(w[q]);
        st.wu.push_back(wu[q]);
        st.wv.push_back(wv[q]);
      }
    }
    st.indptr[i + 1] = std::int64_t(st.indices.size());
  }
  return st;
}

RowSparse position_matrix(const LimitStencils& st, Index n_control) {
  RowSparse Phi(st.rows(), n_control);
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(st.indices.size());
  for (Index i = 0; i < st.rows(); ++i)
    for (std::int64_t k = st.indptr[i]; k < st.indptr[i + 1]; ++k) t.emplace_back(int(i), st.indices[k], st.w[k]);
  Phi.setFromTriplets(t.begin(), t.end());
  return Phi;
}

double rms_distance(const std::vector<FootParam>& fp) {
  double s = 0;
  for (const FootParam& f : fp) s += f.distance * f.distance;
  return fp.empty() ? 0 : std::sqrt(s / double(fp.size()));
}

}  // namespace

SubdivisionMultires decompose_subdivision(const Eigen::Ref<const RowMatrixX3d>& V,
                                          const Eigen::Ref<const RowMatrixX3i>& F,
                                          const Eigen::Ref<const RowMatrixX3d>& CV,
                                          const std::vector<std::int32_t>& face_sizes,
                                          const std::vector<std::int32_t>& face_vertices,
                                          const SubdivOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  check_options(options);
  check_fine_mesh(V, F);
  require_finite_rows(CV, "SubdivisionMultires (control points)");
  check_control_mesh(options.scheme, CV.rows(), face_sizes, face_vertices);
  const int threads = options.threads;

  SubdivisionMultires m;
  m.scheme = options.scheme;
  m.fine = V;
  m.faces = F;
  m.rest_normals = vertex_normals(V, F, threads);
  for (Index i = 0; i < V.rows(); ++i)
    VPFFD_CHECK(m.rest_normals.row(i).squaredNorm() > 0, "SubdivisionMultires: the area-weighted normal of vertex ",
                i, " vanishes (it is in no face, or its faces cancel out), so it has no tangent plane");
  m.diagonal = (V.colwise().maxCoeff() - V.colwise().minCoeff()).norm();
  m.control_face_sizes = face_sizes;
  m.control_faces = face_vertices;
  const double tol = kFootPointTolerance * m.diagonal;

  LimitSurface surface(options.scheme, CV.rows(), face_sizes, face_vertices, options.approx_level);
  RowMatrixX3d C = CV;
  surface.set_points(C);
  std::vector<FootParam> fp = subdiv::find_foot_points(surface, m.fine, {}, tol, threads);
  m.rms_initial = rms_distance(fp);
  // Stage numbers continue those of the decimation (the decimating overload reports
  // stage 1 of 2 + iterations and sets `first` to 1).
  const int first = options.progress_offset, total = first + 1 + options.iterations;
  if (options.progress) options.progress("foot points", first + 1, total, m.rms_initial);
  if (options.iterations > 0) {
    const Eigen::SparseMatrix<double> K = fairness_form(C.rows(), face_sizes, face_vertices);
    for (int round = 0; round < options.iterations; ++round) {
      // Fit at fixed parameters (every vertex, also one whose foot point is not yet
      // exact: its best point is still the nearest correspondence), then move the
      // parameters to the new surface's foot points.
      const RowSparse Phi = position_matrix(build_stencils(surface, fp), C.rows());
      C = fit_control_points(Phi, m.fine, K, options.fairness, C, threads);
      surface.set_points(C);
      fp = subdiv::find_foot_points(surface, m.fine, fp, tol, threads);
      m.rms_rounds.push_back(rms_distance(fp));
      if (options.progress)
        options.progress(("fit round " + std::to_string(round + 1)).c_str(), first + 2 + round, total,
                         m.rms_rounds.back());
    }
  }
  m.control_points = C;
  m.stencils = build_stencils(surface, fp);

  const Index n = V.rows();
  m.patch.resize(n);
  m.u.resize(n);
  m.v.resize(n);
  m.d.resize(n);
  m.residual.resize(n);
  for (auto& c : m.coef) c.resize(n);
  std::vector<char> degenerate(n, 0);
  parallel_range(n, threads, [&](Index b, Index e) {
    for (Index i = b; i < e; ++i) {
      // The frame data from the stencils themselves, so that the identity frame
      // reproduces what the decomposition measured.
      Vector3d s = Vector3d::Zero(), su = Vector3d::Zero(), sv = Vector3d::Zero();
      for (std::int64_t k = m.stencils.indptr[i]; k < m.stencils.indptr[i + 1]; ++k) {
        const Vector3d c = C.row(m.stencils.indices[k]);
        s += m.stencils.w[k] * c;
        su += m.stencils.wu[k] * c;
        sv += m.stencils.wv[k] * c;
      }
      const Vector3d cr = su.cross(sv);
      if (!(cr.norm() > 0)) {
        degenerate[i] = 1;
        continue;
      }
      const Vector3d ns = cr.normalized();
      const Vector3d p = V.row(i);
      m.patch[i] = fp[i].patch;
      m.u[i] = fp[i].u;
      m.v[i] = fp[i].v;
      m.d[i] = (p - s).dot(ns);
      m.residual[i] = tangential_residual(p, s, ns);
      const NormalCoefficients c = normal_coefficients(su, sv, m.rest_normals.row(i).transpose());
      for (int k = 0; k < 6; ++k) m.coef[k][i] = c[k];
    }
  });
  for (Index i = 0; i < n; ++i) {
    VPFFD_CHECK(!degenerate[i], "SubdivisionMultires: the limit surface has no tangent plane at the foot point of "
                                "vertex ", i, " (S_u x S_v = 0)");
    if (m.residual[i] > tol) m.unresolved.push_back(std::int32_t(i));
  }
  m.rms_final = 0;
  for (double d : m.d) m.rms_final += d * d;
  m.rms_final = n ? std::sqrt(m.rms_final / double(n)) : 0;
  if (Index(m.unresolved.size()) > options.max_unresolved) {
    std::ostringstream first;
    for (size_t k = 0; k < std::min<size_t>(5, m.unresolved.size()); ++k)
      first << (k ? ", " : "") << m.unresolved[k];
    throw InvalidInputError("SubdivisionMultires: " + std::to_string(m.unresolved.size()) + " of " +
                            std::to_string(n) + " fine vertices have no exact foot point on the limit surface "
                            "(tangential residual above 1e-9 of the bounding-box diagonal; first: " + first.str() +
                            "): the control mesh does not fit the mesh. Use a finer or closer control mesh, or "
                            "accept them with max_unresolved");
  }
  m.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return m;
}

SubdivisionMultires decompose_subdivision(const Eigen::Ref<const RowMatrixX3d>& V,
                                          const Eigen::Ref<const RowMatrixX3i>& F, Index control_vertices,
                                          const SubdivOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  check_options(options);
  check_fine_mesh(V, F);
  VPFFD_CHECK(control_vertices >= 4 && control_vertices <= V.rows(),
              "SubdivisionMultires: control_vertices must be in 4..", V.rows(), " (the fine mesh's vertices), got ",
              control_vertices);
  auto [CV, CF] = decimate_mesh(V, F, control_vertices);
  std::vector<std::int32_t> sizes(CF.rows(), 3), verts(CF.data(), CF.data() + CF.size());
  SubdivOptions rest = options;
  rest.progress_offset = 1;
  if (options.progress) options.progress("control mesh", 1, 2 + options.iterations, 0.0);
  SubdivisionMultires m = decompose_subdivision(V, F, CV, sizes, verts, rest);
  m.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return m;
}

}  // namespace vpffd
