// A control mesh by decimation: OpenMesh's Decimater with the quadric error module
// (priority) and the normal-flipping module (refuses collapses that turn a face
// over), halfedge collapses only, so the control points are fine vertices and the
// topology (genus, manifoldness) is kept: OpenMesh checks every collapse.

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Tools/Decimater/DecimaterT.hh>
#include <OpenMesh/Tools/Decimater/ModNormalFlippingT.hh>
#include <OpenMesh/Tools/Decimater/ModQuadricT.hh>

#include "vpffd/core/check.h"
#include "vpffd/mesh/validate.h"
#include "vpffd/subdiv/subdivision_multires.h"

namespace vpffd {

namespace {

struct DoubleTraits : OpenMesh::DefaultTraits {
  using Point = OpenMesh::Vec3d;
  using Normal = OpenMesh::Vec3d;
};
using OMesh = OpenMesh::TriMesh_ArrayKernelT<DoubleTraits>;

}  // namespace

std::pair<RowMatrixX3d, RowMatrixX3i> decimate_mesh(const Eigen::Ref<const RowMatrixX3d>& V,
                                                    const Eigen::Ref<const RowMatrixX3i>& F, Index target) {
  VPFFD_CHECK(target >= 4, "SubdivisionMultires: control_vertices must be at least 4, got ", target);
  validate_mesh(V, F, "decimate_mesh");
  OMesh mesh;
  std::vector<OMesh::VertexHandle> vh(V.rows());
  for (Index i = 0; i < V.rows(); ++i) vh[i] = mesh.add_vertex(OMesh::Point(V(i, 0), V(i, 1), V(i, 2)));
  for (Index f = 0; f < F.rows(); ++f) {
    const OMesh::FaceHandle h = mesh.add_face(vh[F(f, 0)], vh[F(f, 1)], vh[F(f, 2)]);
    VPFFD_CHECK(h.is_valid(), "SubdivisionMultires: fine face ", f,
                " makes the mesh non-manifold (OpenMesh refused it), so it cannot be decimated");
  }
  mesh.request_vertex_status();
  mesh.request_edge_status();
  mesh.request_face_status();
  mesh.request_face_normals();
  mesh.update_face_normals();

  OpenMesh::Decimater::DecimaterT<OMesh> dec(mesh);
  OpenMesh::Decimater::ModQuadricT<OMesh>::Handle quadric;
  OpenMesh::Decimater::ModNormalFlippingT<OMesh>::Handle flips;
  dec.add(quadric);
  dec.add(flips);
  dec.module(quadric).unset_max_err();
  // Collapses that tilt a face's normal by more than 60 degrees are refused: a
  // control mesh that stays close to the surface's orientation has foot points.
  dec.module(flips).set_max_normal_deviation(60.0);
  VPFFD_CHECK(dec.initialize(), "SubdivisionMultires: OpenMesh's decimater did not initialise");
  if (Index(mesh.n_vertices()) > target) dec.decimate_to(size_t(target));
  mesh.garbage_collection();

  RowMatrixX3d CV(mesh.n_vertices(), 3);
  for (const auto v : mesh.vertices()) {
    const OMesh::Point& q = mesh.point(v);
    CV.row(v.idx()) << q[0], q[1], q[2];
  }
  RowMatrixX3i CF(mesh.n_faces(), 3);
  for (const auto f : mesh.faces()) {
    int c = 0;
    for (const auto v : mesh.fv_range(f)) CF(f.idx(), c++) = v.idx();
  }
  return {std::move(CV), std::move(CF)};
}

}  // namespace vpffd
