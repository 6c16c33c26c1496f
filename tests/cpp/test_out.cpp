// Frames into the caller's arrays: the pointer overloads give the bits of the
// overloads that return new matrices (Deformer, MultiresFFD, and on Vulkan
// VulkanDeformer and VulkanMultires).

#include <gtest/gtest.h>

#include <cstring>
#include <limits>

#include "helpers.h"
#include "vpffd/vpffd.h"

#ifdef VPFFD_HAS_VULKAN
#include "vpffd/backend/vulkan.h"
#include "vpffd/backend/vulkan_multires.h"
#endif

namespace out_test {

using namespace vpffd;

bool bits_equal(const RowMatrixX3d& a, const RowMatrixX3d& b) {
  return a.rows() == b.rows() && std::memcmp(a.data(), b.data(), sizeof(double) * a.size()) == 0;
}

RowMatrixX3d unwritten(Index n) { return RowMatrixX3d::Constant(n, 3, std::numeric_limits<double>::quiet_NaN()); }

TEST(Out, DeformerFramesIntoCallersArrays) {
  const TriMesh m = icosphere(3);
  const Lattice L = test::lattice_around(m.V, {6, 6, 6}, 3);
  const RowMatrixX3d P = test::squashed(L, 0.7);
  Deformer d(m.V, m.F, L);
  RowMatrixX3d X = unwritten(m.V.rows());
  d.ffd(P, X.data());
  EXPECT_TRUE(bits_equal(X, d.ffd(P)));
  for (bool keep : {true, false}) {
    CorrectionOptions o;
    o.preserve_volume = keep;
    X = unwritten(m.V.rows());
    const DeformResult r = d.deform(P, o, X.data());
    const DeformResult ref = d.deform(P, o);
    EXPECT_EQ(r.vertices.rows(), 0);
    EXPECT_TRUE(bits_equal(X, ref.vertices)) << keep;
    EXPECT_EQ(r.volume, ref.volume);
  }
  const RowMatrixX3d N0 = vertex_normals(m.V, m.F);
  RowMatrixX3d N = unwritten(m.V.rows());
  d.deformed_normals(P, N0, N.data());
  EXPECT_TRUE(bits_equal(N, d.deformed_normals(P, N0)));
}

TEST(Out, MultiresIntoCallersArrays) {
  const TriMesh m = test::bumpy(3);
  auto mr = std::make_shared<Multires>(decompose(m.V, m.F, 5.0));
  const Lattice L = test::lattice_around(m.V, {5, 5, 5}, 3, 0.1);
  const RowMatrixX3d P = test::squashed(L, 0.8);
  MultiresFFD f(mr, L);
  RowMatrixX3d X = unwritten(m.V.rows()), N = unwritten(m.V.rows());
  f.deform(P, X.data(), N.data());
  const MultiresFrame ref = f.deform(P);
  EXPECT_TRUE(bits_equal(X, ref.vertices) && bits_equal(N, ref.normals));
}

#ifdef VPFFD_HAS_VULKAN
bool out_have_device() {
  for (const auto& dev : vulkan::devices())
    if (dev.suitable) return true;
  return false;
}

TEST(Out, VulkanIntoCallersArrays) {
  if (!out_have_device()) GTEST_SKIP() << "no suitable Vulkan device";
  const TriMesh m = icosphere(3);
  const Lattice L = test::lattice_around(m.V, {6, 6, 6}, 3);
  const RowMatrixX3d P = test::squashed(L, 0.7);
  vulkan::VulkanDeformer d(m.V, m.F, L);
  CorrectionOptions o;
  RowMatrixX3d X = unwritten(m.V.rows()), N = unwritten(m.V.rows()), Nref;
  const DeformResult r = d.deform(P, o, X.data(), N.data());
  const DeformResult ref = d.deform(P, o, true, &Nref);
  EXPECT_EQ(r.vertices.rows(), 0);
  EXPECT_TRUE(bits_equal(X, ref.vertices) && bits_equal(N, Nref));

  auto mr = std::make_shared<Multires>(decompose(test::bumpy(3).V, m.F, 5.0));
  vulkan::VulkanMultires vm(mr, L);
  X = unwritten(m.V.rows());
  N = unwritten(m.V.rows());
  vm.deform(P, X.data(), N.data());
  const MultiresFrame f = vm.deform(P);
  EXPECT_TRUE(bits_equal(X, f.vertices) && bits_equal(N, f.normals));
}
#endif

}  // namespace out_test
