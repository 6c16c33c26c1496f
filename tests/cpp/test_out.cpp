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

// The shared-pointer overload: the bits of the others; a held result keeps its values
// through later frames and after the deformer is gone; memory let go of is used again.
TEST(Out, VulkanSharedVertices) {
  if (!out_have_device()) GTEST_SKIP() << "no suitable Vulkan device";
  const TriMesh m = icosphere(3);
  const Index n = m.V.rows();
  const Lattice L = test::lattice_around(m.V, {6, 6, 6}, 3);
  const RowMatrixX3d P = test::squashed(L, 0.7), Q = test::squashed(L, 1.2);
  auto view = [&](const std::shared_ptr<const double>& p) { return RowMatrixX3d(Eigen::Map<const RowMatrixX3d>(p.get(), n, 3)); };
  std::shared_ptr<const double> held[5];
  RowMatrixX3d refP, refQ;
  {
    vulkan::VulkanDeformer d(m.V, m.F, L);
    CorrectionOptions o;
    refP = d.deform(P, o).vertices;
    refQ = d.deform(Q, o).vertices;
    for (auto& h : held) EXPECT_EQ(d.deform(P, o, &h).vertices.rows(), 0);  // more than the pool keeps
    for (const auto& h : held) EXPECT_TRUE(bits_equal(view(h), refP));
    std::shared_ptr<const double> q;
    for (int i = 0; i < 3; ++i) d.deform(Q, o, &q);
    EXPECT_TRUE(bits_equal(view(q), refQ));
    for (const auto& h : held) EXPECT_TRUE(bits_equal(view(h), refP));
    const double* first = held[0].get();
    held[0].reset();
    std::shared_ptr<const double> again;
    d.deform(Q, o, &again);
    EXPECT_EQ(again.get(), first);  // pooled in both precisions
    EXPECT_TRUE(bits_equal(view(again), refQ));
  }
  for (int i = 1; i < 5; ++i) EXPECT_TRUE(bits_equal(view(held[i]), refP));  // after the deformer
}
#endif

}  // namespace out_test
