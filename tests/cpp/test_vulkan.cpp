// The Vulkan backend against the CPU reference (runs on lavapipe without a GPU).

#include <gtest/gtest.h>

#include <limits>

#include <cmath>
#include <memory>
#include <thread>

#include "helpers.h"
#include "vpffd/vpffd.h"

#ifdef VPFFD_HAS_VULKAN
#include "vpffd/backend/vulkan.h"
#include "vpffd/backend/vulkan_multires.h"

namespace {

using namespace vpffd;

bool have_device() {
  for (const auto& d : vulkan::devices())
    if (d.suitable) return true;
  return false;
}

bool have_float64() {
  for (const auto& d : vulkan::devices())
    if (d.suitable && d.float64) return true;
  return false;
}

#define REQUIRE_DEVICE() \
  if (!have_device()) GTEST_SKIP() << "no suitable Vulkan device"

// The frame tests run in both precisions (shaders/real.glsl).
class VulkanP : public ::testing::TestWithParam<vulkan::Precision> {
 protected:
  void SetUp() override {
    if (!have_device()) GTEST_SKIP() << "no suitable Vulkan device";
    if (GetParam() == vulkan::Precision::Float64 && !have_float64()) GTEST_SKIP() << "no shaderFloat64";
  }
  std::unique_ptr<vulkan::VulkanDeformer> make(const RowMatrixX3d& V, const RowMatrixX3i& F, const Lattice& L) const {
    auto d = std::make_unique<vulkan::VulkanDeformer>(V, F, L, OutsidePolicy::Error, "", GetParam());
    EXPECT_EQ(d->precision(), GetParam());
    return d;
  }
};

struct Scene {
  RowMatrixX3d V;
  RowMatrixX3i F;
  Lattice L;
};

Scene sphere(int subdiv, int degree, std::array<int, 3> dims) {
  Scene s;
  auto m = icosphere(subdiv);
  s.V = m.V;
  s.F = m.F;
  s.L = make_lattice(Vector3d::Constant(-1.1), Vector3d::Constant(1.2), dims, {degree, degree, degree});
  return s;
}

/// The unit sphere in a quadratic 8^3 lattice over [-3, 3]^3: room to move it around,
/// and control points that touch none of its vertices.
Scene sphere_in_big_lattice(int subdiv) {
  Scene s = sphere(subdiv, 2, {8, 8, 8});
  s.L = make_lattice(Vector3d::Constant(-3), Vector3d::Constant(3), {8, 8, 8}, {2, 2, 2});
  return s;
}

// A smooth, volume-changing edit of the rest control points.
RowMatrixX3d edit(const Lattice& L) {
  RowMatrixX3d P = rest_control_points(L);
  for (Index c = 0; c < P.rows(); ++c) {
    const double x = P(c, 0), y = P(c, 1), z = P(c, 2);
    P(c, 0) = x * (1.0 + 0.3 * z) + 0.1 * y * y;
    P(c, 1) = y * 0.8 + 0.05 * x;
    P(c, 2) = z * 1.2 + 0.1 * std::sin(2 * x);
  }
  return P;
}

// Bounds of the device against the CPU, derived from the device's arithmetic (see
// tests/python/gpu_bounds.py for the derivation): float32 positions relative to the
// lattice centre, float32 basis values from power forms, float64 or float-float sums.
// They hold for any correctly rounding driver, on any CPU or GPU.
struct Bounds {
  double vertex = 0, corrected_volume = 0, plain_volume = 0;
};

Bounds bounds(const DeformResult& c, const RowMatrixX3i& F, const Lattice& L, const RowMatrixX3d& P) {
  const double u = std::ldexp(1.0, -24), u_sum = std::ldexp(1.0, -44);
  double basis = 0, terms = 1;
  for (int a = 0; a < 3; ++a) {
    const int d = L.degree[a];
    basis += (3 * d + 2) * std::ldexp(1.0, d) * (d + 1);
    terms *= d + 1;
  }
  const double per_op = basis + terms + 3;
  const Vector3d o = 0.5 * (L.box_min + L.box_max);
  const RowMatrixX3d Y = c.vertices.rowwise() - o.transpose();
  double delta = c.offsets.cwiseAbs().maxCoeff();
  for (const AxisStep& st : c.steps) delta = std::max(delta, st.max_offset);
  const double step_error = u * (per_op * delta + Y.cwiseAbs().maxCoeff());
  // A periodic lattice: the device evaluates the extended control points, and adds
  // the wrap's and the shift seam's terms (gpu_bounds.py, _periodic_error).
  const RowMatrixX3d Pe = expand_points(make_ties(L), P);
  const double R = (Pe.rowwise() - o.transpose()).cwiseAbs().maxCoeff(), y_max = Y.cwiseAbs().maxCoeff();
  double periodic = 0;
  if (L.any_periodic()) {
    double lip = 0;
    bool shift = false;
    for (int a = 0; a < 3; ++a) {
      double h = std::numeric_limits<double>::infinity();
      for (size_t i = 0; i + 1 < L.knots[a].size(); ++i)
        if (L.knots[a][i + 1] > L.knots[a][i]) h = std::min(h, L.knots[a][i + 1] - L.knots[a][i]);
      h *= (L.box_max[a] - L.box_min[a]) / (L.domain_hi(a) - L.domain_lo(a));
      lip += 2 * L.degree[a] * R / h;
      shift |= L.seam[a] == Seam::Shift;
    }
    periodic = 4 * u_sum * (y_max + (L.box_max - L.box_min).maxCoeff()) * (lip + (shift ? 1.0 : 0.0)) +
               (shift ? u * (2 * y_max + R) : 0.0);
  }
  Bounds b;
  b.vertex = u * per_op * R + periodic + double(std::max<size_t>(c.steps.size(), 1)) * step_error;
  // |dV/dy_v|: the cone volume's gradient, sum over the faces at v of y_j x y_k / 6.
  RowMatrixX3d G = RowMatrixX3d::Zero(Y.rows(), 3);
  for (Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const Vector3d yj = Y.row(F(f, (k + 1) % 3)), yk = Y.row(F(f, (k + 2) % 3));
      G.row(F(f, k)) += yj.cross(yk).transpose() / 6.0;
    }
  G = G.cwiseAbs();
  const double sum_error = 3.0 * double(F.rows()) * u_sum * Y.cwiseAbs().maxCoeff() * G.sum();
  b.corrected_volume = step_error * G.colwise().sum().maxCoeff() + sum_error;
  b.plain_volume = b.vertex * G.sum() + sum_error;
  return b;
}

void expect_close(const DeformResult& g, const DeformResult& c, const RowMatrixX3i& F, const Lattice& L,
                  const RowMatrixX3d& P) {
  const Bounds b = bounds(c, F, L, P);
  ASSERT_EQ(g.vertices.rows(), c.vertices.rows());
  EXPECT_LE((g.vertices - c.vertices).cwiseAbs().maxCoeff(), b.vertex);
  const bool corrected = !std::isnan(c.target_volume);
  if (corrected) {
    const double cpu_miss = std::abs(c.volume - c.target_volume) + 1e-12 * std::abs(c.target_volume);
    EXPECT_LE(std::abs(g.volume - g.target_volume), b.corrected_volume);
    EXPECT_LE(std::abs(g.volume - c.volume), b.corrected_volume + cpu_miss);
  } else {
    EXPECT_LE(std::abs(g.volume - c.volume), b.plain_volume);
  }
  ASSERT_EQ(g.steps.size(), c.steps.size());
}

// The device's offsets explain its vertices: the FFD in double of its corrected
// control points is its vertices, within the vertex bound.
void expect_offsets_explain_vertices(const Deformer& cpu, const DeformResult& g, const DeformResult& c,
                                     const Lattice& L, const RowMatrixX3d& P) {
  const Bounds b = bounds(c, cpu.faces(), L, P);
  EXPECT_LE((cpu.ffd(g.control_points) - g.vertices).cwiseAbs().maxCoeff(), b.vertex);
}

// Normals on the device (normals.comp) under an affine map x -> A x, which the FFD of
// the mapped rest control points reproduces exactly (J = A everywhere): the exact
// normal is cof(A) n0. The bound is the Python tests' (gpu_bounds.normal_angle_bound)
// with the per-vertex basis sums replaced by their worst cases for clamped uniform
// knots of degree d, in tau units: sum |B| = 1, sum |B'| <= 2d, sum |B''| <= 4d(d-1)
// (the derivative formula applied once and twice), the real arithmetic's terms
// (< 1e-9) added whole: per column of J an error of at most
//   1.01 [R (eD + 2 S eB) + (3K + 3) u R S + 2 u R S],
//   eB = u (1 + 2d) + 1e-9, eD = g (u (2d + 4d(d-1)) + 1e-9), S = 2d g,
// (R = max |q - o|, g = 1 / span width), and an angle of at most
// asin(|dn| / |cof(A) n0|) with |dn| <= sum_a |n0_a| (2 e |A| + e^2 + 7 u (|A| + e)^2).
TEST_P(VulkanP, NormalsOfAnAffineMap) {
  Scene s = sphere(3, 3, {5, 5, 5});
  auto gpu = make(s.V, s.F, s.L);
  Eigen::Matrix3d A;
  A << 1.1, 0.2, 0.0, 0.0, 0.9, 0.1, 0.1, 0.0, 1.2;
  const RowMatrixX3d P = rest_control_points(s.L) * A.transpose();
  CorrectionOptions plain;
  plain.preserve_volume = false;
  RowMatrixX3d N;
  const DeformResult r = gpu->deform(P, plain, true, &N);
  ASSERT_EQ(N.rows(), s.V.rows());
  // The normals change nothing else: the same frame without them gives the same result.
  const DeformResult r2 = gpu->deform(P, plain);
  EXPECT_TRUE(r.vertices == r2.vertices);

  const double u = std::ldexp(1.0, -24);
  const int d = 3;
  const double h = (s.L.box_max[0] - s.L.box_min[0]) / (5 - d), g = 1 / h;
  const Vector3d o = 0.5 * (s.L.box_min + s.L.box_max);
  const double R = (P.rowwise() - o.transpose()).rowwise().norm().maxCoeff();
  const double eB = u * (1 + 2 * d) + 1e-9, eD = g * (u * (2 * d + 4 * d * (d - 1)) + 1e-9), S = 2 * d * g;
  const double e = 1.01 * (R * (eD + 2 * S * eB) + (3 * (d + 1) + 3) * u * R * S + 2 * u * R * S);
  const double nA = A.colwise().norm().maxCoeff();
  const Eigen::Matrix3d cof = A.determinant() * A.inverse().transpose();
  const RowMatrixX3d n0 = vertex_normals(s.V, s.F);
  double worst = 0;
  for (Index v = 0; v < s.V.rows(); ++v) {
    const Vector3d want = cof * n0.row(v).transpose(), got = N.row(v).transpose();
    const double dn = n0.row(v).cwiseAbs().sum() * (2 * e * nA + e * e + 7 * u * (nA + e) * (nA + e));
    const double bound = std::asin(std::min(1.0, dn / want.norm())) + 2 * u;
    const double angle = std::atan2(got.cross(want).norm(), got.dot(want));
    EXPECT_LE(angle, bound) << "vertex " << v;
    EXPECT_NEAR(got.norm(), 1.0, 1e-6);
    worst = std::max(worst, bound);
  }
  EXPECT_LT(worst, 0.01 / 180 * std::acos(-1.0));  // the bound proves the 0.01 degree
}

TEST(Vulkan, DevicesListed) {
  std::string why;
  const auto ds = vulkan::devices(&why);
  if (ds.empty()) GTEST_SKIP() << why;
  for (const auto& d : ds) {
    EXPECT_FALSE(d.name.empty());
    EXPECT_FALSE(d.type.empty());
  }
}

TEST_P(VulkanP, MatchesCpuAllAxisSubsets) {
  Scene s = sphere(3, 3, {5, 6, 5});
  Deformer cpu(s.V, s.F, s.L);
  auto gpu_ptr = make(s.V, s.F, s.L);
  vulkan::VulkanDeformer& gpu = *gpu_ptr;
  const RowMatrixX3d P = edit(s.L);
  for (const char* axes : {"x", "y", "z", "xy", "yz", "zx", "xyz", "zyx"}) {
    CorrectionOptions o;
    o.axes = parse_axes(axes);
    const DeformResult c = cpu.deform(P, o), g = gpu.deform(P, o);
    SCOPED_TRACE(axes);
    expect_close(g, c, s.F, s.L, P);
    expect_offsets_explain_vertices(cpu, g, c, s.L, P);
  }
}

TEST_P(VulkanP, WeightsFixedConstraintsAndDegrees) {
  for (int degree : {1, 2, 4, 5}) {
    Scene s = sphere(2, degree, {degree + 3, degree + 2, degree + 4});
    Deformer cpu(s.V, s.F, s.L);
    auto gpu_ptr = make(s.V, s.F, s.L);
  vulkan::VulkanDeformer& gpu = *gpu_ptr;
    const Index N = s.L.n_control_points();
    CorrectionOptions o;
    o.weights = VectorXd::LinSpaced(N, 1.0, 3.0);
    o.fixed.assign(N, 0);
    o.fixed[0] = o.fixed[N - 1] = 1;
    PointConstraint pc;
    pc.vertex = 0;
    pc.target = s.V.row(0).transpose() + Vector3d(0.05, -0.02, 0.03);
    o.constraints.push_back(pc);
    const RowMatrixX3d P = edit(s.L);
    const DeformResult c = cpu.deform(P, o), g = gpu.deform(P, o);
    SCOPED_TRACE(degree);
    expect_close(g, c, s.F, s.L, P);
    EXPECT_LE(g.constraint_error, 1e-9);
    EXPECT_EQ(g.offsets(0, 0), 0.0);
  }
}

TEST_P(VulkanP, RoundsAndManyConstraints) {
  Scene s = sphere(3, 3, {6, 6, 6});
  Deformer cpu(s.V, s.F, s.L);
  auto gpu_ptr = make(s.V, s.F, s.L);
  vulkan::VulkanDeformer& gpu = *gpu_ptr;
  const RowMatrixX3d P = edit(s.L);
  const RowMatrixX3d X = cpu.ffd(P);
  CorrectionOptions o;
  o.rounds = 3;
  for (Index v = 0; v < s.V.rows() && o.constraints.size() < 60; v += 10) {
    PointConstraint pc;
    pc.vertex = v;
    pc.target = X.row(v).transpose() + Vector3d(0.01, -0.005, 0.008) * std::sin(double(v));
    o.constraints.push_back(pc);
  }
  ASSERT_EQ(o.constraints.size(), 60u);  // more than the old device limit of 31
  for (bool volume : {true, false}) {
    o.preserve_volume = volume;
    const DeformResult c = cpu.deform(P, o), g = gpu.deform(P, o);
    SCOPED_TRACE(volume);
    expect_close(g, c, s.F, s.L, P);
    EXPECT_LE(g.constraint_error, 1e-9);
    expect_offsets_explain_vertices(cpu, g, c, s.L, P);
  }
}

TEST_P(VulkanP, SameErrorsAsCpu) {
  // A small sphere in a big lattice: the corner control point does not touch it.
  Scene s = sphere_in_big_lattice(2);
  Deformer cpu(s.V, s.F, s.L);
  auto gpu_ptr = make(s.V, s.F, s.L);
  vulkan::VulkanDeformer& gpu = *gpu_ptr;
  const RowMatrixX3d P = rest_control_points(s.L);
  auto message = [](auto&& f) -> std::string {
    try {
      f();
    } catch (const SolverError& e) {
      return std::string("SolverError: ") + e.what();
    } catch (const InvalidInputError& e) {
      return std::string("InvalidInputError: ") + e.what();
    }
    return "";
  };
  auto same = [&](const CorrectionOptions& o, const RowMatrixX3d& PP) {
    const std::string a = message([&] { cpu.deform(PP, o); });
    const std::string b = message([&] { gpu.deform(PP, o); });
    EXPECT_FALSE(a.empty());
    EXPECT_EQ(a, b);
  };
  CorrectionOptions corner_free;  // zero volume coefficients on the device
  corner_free.fixed.assign(s.L.n_control_points(), 1);
  corner_free.fixed[0] = 0;
  same(corner_free, P);
  CorrectionOptions all_fixed;  // checked on the host
  all_fixed.fixed.assign(s.L.n_control_points(), 1);
  same(all_fixed, P);
  CorrectionOptions twice;  // dependent constraint rows: the host's check of the block
  PointConstraint pc;
  pc.vertex = 3;
  pc.target = s.V.row(3).transpose();
  twice.constraints = {pc, pc};
  twice.preserve_volume = false;
  same(twice, P);
  CorrectionOptions bad_axes;
  bad_axes.axes = {};
  same(bad_axes, P);
  // Repeated axes: the device sizes its per-step buffers for 3 distinct axes x kMaxRounds.
  CorrectionOptions repeated;
  repeated.axes = {0, 0, 0, 0};
  repeated.rounds = kMaxRounds;
  same(repeated, P);
  same(CorrectionOptions{}, P.topRows(3));
  RowMatrixX3i Fbad = s.F;
  Fbad(0, 0) = 100000;
  EXPECT_THROW(vulkan::VulkanDeformer(s.V, Fbad, s.L), InvalidInputError);
}

TEST_P(VulkanP, SecondDeformerAndManyFrames) {
  Scene s = sphere(2, 3, {5, 5, 5});
  auto pa = make(s.V, s.F, s.L), pb = make(s.V, s.F, s.L);
  vulkan::VulkanDeformer &a = *pa, &b = *pb;
  const RowMatrixX3d P = edit(s.L);
  const DeformResult ra = a.deform(P, {}), rb = b.deform(P, {});
  EXPECT_EQ((ra.vertices - rb.vertices).cwiseAbs().maxCoeff(), 0.0);  // deterministic
  for (int f = 0; f < 20; ++f) a.deform(P * (1.0 + 0.01 * f), {}, false);
  EXPECT_LE(std::abs(a.deform(P, {}).volume - ra.volume), 1e-12 * std::abs(ra.volume));
}

// set_rest_vertices: the device embeds and sorts the moved vertices. Plain frames equal
// those of a deformer built on the moved mesh bit for bit (the same operations on the
// same positions); corrected ones match the moved CPU Deformer within the bounds above,
// which hold for the device's embedding as tests/python/test_vulkan_motion.py derives
// (the reals' error in tau, 4 2^-44 max|u| / min span width, is far below float32's).
TEST_P(VulkanP, MovedRestEqualsFreshAndCpu) {
  Scene s = sphere_in_big_lattice(3);
  Deformer cpu(s.V, s.F, s.L);
  auto gpu_ptr = make(s.V, s.F, s.L);
  vulkan::VulkanDeformer& gpu = *gpu_ptr;
  const RowMatrixX3d P = edit(s.L);
  CorrectionOptions plain;
  plain.preserve_volume = false;
  const DeformResult first = gpu.deform(P, {});
  for (int step = 1; step <= 3; ++step) {
    SCOPED_TRACE(step);
    RowMatrixX3d X = s.V * (1.0 + 0.1 * step);
    X.col(0).array() += 0.5 * step;  // x = 0.5 step + ...: the knots at integers are crossed
    X.col(2).array() -= 0.3 * step;
    gpu.set_rest_vertices(X);
    cpu.set_rest_vertices(X);
    EXPECT_EQ((gpu.rest_vertices() - X).cwiseAbs().maxCoeff(), 0.0);
    // Before a frame the device vertices are the rest positions rounded to float32
    // (relative to the origin): half an ulp, at most 2^-24 |x - o|.
    const Vector3d o = gpu.origin();
    EXPECT_LE((gpu.vertices() - X).cwiseAbs().maxCoeff(),
              std::ldexp(1.0, -24) * (X.rowwise() - o.transpose()).cwiseAbs().maxCoeff());
    vulkan::VulkanDeformer fresh(X, s.F, s.L, OutsidePolicy::Error, "", GetParam());
    const DeformResult a = gpu.deform(P, plain), b = fresh.deform(P, plain);
    EXPECT_EQ((a.vertices - b.vertices).cwiseAbs().maxCoeff(), 0.0);
    const DeformResult g = gpu.deform(P, {}), c = cpu.deform(P, {});
    expect_close(g, c, s.F, s.L, P);
    expect_offsets_explain_vertices(cpu, g, c, s.L, P);
    EXPECT_EQ(g.target_volume, gpu.rest_volume());
    // The CPU twin follows the move (re-embedded on this first use).
    EXPECT_EQ((gpu.cpu().ffd(P) - cpu.ffd(P)).cwiseAbs().maxCoeff(), 0.0);
  }
  // Back to the construction's positions: the construction's frame, bit for bit.
  gpu.set_rest_vertices(s.V);
  const DeformResult back = gpu.deform(P, {});
  EXPECT_EQ((back.vertices - first.vertices).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(back.volume, first.volume);
}

// A move's device work waits for the next frame's submission: moves in a row embed
// only the last, a refused move or a frame refused on the host before submitting
// leave it waiting, and vertices() read before a frame runs it alone.
TEST_P(VulkanP, MovesWaitForTheNextFrame) {
  Scene s = sphere_in_big_lattice(3);
  auto gpu_ptr = make(s.V, s.F, s.L);
  vulkan::VulkanDeformer& gpu = *gpu_ptr;
  const RowMatrixX3d P = edit(s.L);
  RowMatrixX3d X1 = s.V, X2 = s.V * 1.2;
  X1.col(0).array() += 0.7;
  X2.col(2).array() -= 0.9;
  vulkan::VulkanDeformer fresh(X2, s.F, s.L, OutsidePolicy::Error, "", GetParam());
  CorrectionOptions plain;
  plain.preserve_volume = false;
  gpu.set_rest_vertices(X1);
  gpu.set_rest_vertices(X2);
  // A refused move stages its positions as it tests them: X2 must still be what embeds.
  RowMatrixX3d bad = X1;
  bad(bad.rows() - 1, 1) = std::nan("");
  EXPECT_THROW(gpu.set_rest_vertices(bad), InvalidInputError);
  EXPECT_THROW(gpu.deform(P.topRows(P.rows() - 1), plain), InvalidInputError);  // refused before submitting
  const DeformResult a = gpu.deform(P, plain), b = fresh.deform(P, plain);
  EXPECT_EQ((a.vertices - b.vertices).cwiseAbs().maxCoeff(), 0.0);
  const Deformer cpu(X2, s.F, s.L);
  expect_close(gpu.deform(P, {}), cpu.deform(P, {}), s.F, s.L, P);
  // Read before a frame: the rest positions (float32 of X - origin), then the frame.
  gpu.set_rest_vertices(X1);
  const Vector3d o = gpu.origin();
  EXPECT_LE((gpu.vertices() - X1).cwiseAbs().maxCoeff(),
            std::ldexp(1.0, -24) * (X1.rowwise() - o.transpose()).cwiseAbs().maxCoeff());
  vulkan::VulkanDeformer fresh1(X1, s.F, s.L, OutsidePolicy::Error, "", GetParam());
  EXPECT_EQ((gpu.deform(P, plain).vertices - fresh1.deform(P, plain).vertices).cwiseAbs().maxCoeff(), 0.0);
}

// set_rest_offsets: the device adds the offset to the base positions it keeps (one
// more rounding in its reals, far below float32's), so frames match the CPU Deformer
// moved by the same offsets within the bounds above; both keep the base's rest volume.
// A move by positions still waiting when the offsets come runs first, alone; vertices()
// read before a frame runs the offset move's embedding alone.
TEST_P(VulkanP, OffsetMovesMatchCpu) {
  Scene s = sphere_in_big_lattice(3);
  Deformer cpu(s.V, s.F, s.L);
  auto gpu_ptr = make(s.V, s.F, s.L);
  vulkan::VulkanDeformer& gpu = *gpu_ptr;
  const RowMatrixX3d P = edit(s.L);
  const double V0 = gpu.rest_volume();
  for (int step = 1; step <= 3; ++step) {
    SCOPED_TRACE(step);
    RowMatrixX3d O(1, 3);
    O << 0.5 * step, -0.2 * step, 0.3;
    gpu.set_rest_offsets(O);
    cpu.set_rest_offsets(O);
    const RowMatrixX3d X = s.V.rowwise() + O.row(0);
    EXPECT_EQ((gpu.rest_vertices() - X).cwiseAbs().maxCoeff(), 0.0);
    const Vector3d o = gpu.origin();
    EXPECT_LE((gpu.vertices() - X).cwiseAbs().maxCoeff(),
              std::ldexp(1.0, -24) * (X.rowwise() - o.transpose()).cwiseAbs().maxCoeff());
    const DeformResult g = gpu.deform(P, {}), c = cpu.deform(P, {});
    EXPECT_EQ(g.target_volume, V0);
    EXPECT_EQ(c.target_volume, V0);
    expect_close(g, c, s.F, s.L, P);
  }
  // Positions, then offsets from them before any frame; offsets do not accumulate.
  const RowMatrixX3d Y = s.V * 0.9;
  gpu.set_rest_vertices(Y);
  cpu.set_rest_vertices(Y);
  RowMatrixX3d O(1, 3);
  O << 0.4, 0.0, 0.0;
  gpu.set_rest_offsets(O);
  O << 0.0, 0.6, -0.2;
  gpu.set_rest_offsets(O);
  cpu.set_rest_offsets(O);
  EXPECT_EQ(gpu.rest_volume(), cpu.rest_volume());
  expect_close(gpu.deform(P, {}), cpu.deform(P, {}), s.F, s.L, P);
  // Refused: the wrong count, a non-finite offset, vertices moved out of the box.
  EXPECT_THROW(gpu.set_rest_offsets(RowMatrixX3d::Zero(2, 3)), InvalidInputError);
  RowMatrixX3d bad = O;
  bad(0, 1) = std::nan("");
  EXPECT_THROW(gpu.set_rest_offsets(bad), InvalidInputError);
  bad = O;
  bad(0, 0) = 100.0;
  EXPECT_THROW(gpu.set_rest_offsets(bad), InvalidInputError);
  expect_close(gpu.deform(P, {}), cpu.deform(P, {}), s.F, s.L, P);
}

TEST_P(VulkanP, MovedRestBadInput) {
  Scene s = sphere(2, 3, {5, 5, 5});
  auto gpu_ptr = make(s.V, s.F, s.L);
  vulkan::VulkanDeformer& gpu = *gpu_ptr;
  Deformer cpu(s.V, s.F, s.L);
  const RowMatrixX3d P = edit(s.L);
  const DeformResult before = gpu.deform(P, {});
  RowMatrixX3d X = s.V;
  X.col(0).array() += 0.5;  // the box is [-1.1, 1.2]: x > 1.2 for some of the unit sphere
  Index n_out = 0, first = -1;
  for (Index v = 0; v < X.rows(); ++v)
    if (X(v, 0) > 1.2) {
      ++n_out;
      if (first < 0) first = v;
    }
  ASSERT_GT(n_out, 0);
  std::string gpu_msg, cpu_msg;
  try {
    gpu.set_rest_vertices(X);
  } catch (const InvalidInputError& e) {
    gpu_msg = e.what();
  }
  try {
    cpu.set_rest_vertices(X);
  } catch (const InvalidInputError& e) {
    cpu_msg = e.what();
  }
  EXPECT_EQ(gpu_msg, cpu_msg);
  EXPECT_NE(gpu_msg.find(std::to_string(n_out) + " vertices lie outside"), std::string::npos) << gpu_msg;
  EXPECT_NE(gpu_msg.find("the first is vertex " + std::to_string(first) + " at"), std::string::npos) << gpu_msg;
  // Non-finite coordinates, in the staging loop's blocks of four vertices and in the
  // last vertex (past the last block: the vertex count is not a multiple of four here).
  const Index last = s.V.rows() - 1;
  ASSERT_NE(s.V.rows() % 4, 0);
  for (const Index v : {Index(7), last})
    for (const double bad : {std::nan(""), std::numeric_limits<double>::infinity(),
                             -std::numeric_limits<double>::infinity()}) {
      RowMatrixX3d Y = s.V;
      Y(v, v == last ? 2 : 1) = bad;
      EXPECT_THROW(gpu.set_rest_vertices(Y), InvalidInputError) << v << " " << bad;
    }
  EXPECT_THROW(gpu.set_rest_vertices(s.V.topRows(s.V.rows() - 1)), InvalidInputError);
  // Unchanged after the refusals.
  EXPECT_EQ((gpu.rest_vertices() - s.V).cwiseAbs().maxCoeff(), 0.0);
  const DeformResult again = gpu.deform(P, {});
  EXPECT_EQ((again.vertices - before.vertices).cwiseAbs().maxCoeff(), 0.0);
  // Positions given as three columns of a wider array (a strided view, staged row by
  // row): the same move as from a copy.
  RowMatrixX3d Z = s.V * 0.9;
  Z.col(1).array() += 0.05;
  RowMatrixXd wide = RowMatrixXd::Zero(Z.rows(), 5);
  wide.middleCols(1, 3) = Z;
  CorrectionOptions plain;
  plain.preserve_volume = false;
  gpu.set_rest_vertices(wide.middleCols(1, 3));
  const DeformResult viewed = gpu.deform(P, plain);
  gpu.set_rest_vertices(Z);
  EXPECT_EQ((gpu.deform(P, plain).vertices - viewed.vertices).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ((gpu.rest_vertices() - Z).cwiseAbs().maxCoeff(), 0.0);
}

// A volume correction found impossible on the device, after the frame ran, must not
// leave that frame's vertices behind.
TEST_P(VulkanP, FailedFrameKeepsLastGoodVertices) {
  Scene s = sphere_in_big_lattice(2);
  auto gpu_ptr = make(s.V, s.F, s.L);
  vulkan::VulkanDeformer& gpu = *gpu_ptr;
  const RowMatrixX3d rest = gpu.vertices();
  CorrectionOptions corner_free;  // zero volume coefficients, found by the device's solve
  corner_free.fixed.assign(s.L.n_control_points(), 1);
  corner_free.fixed[0] = 0;
  const RowMatrixX3d P = rest_control_points(s.L) * 1.2;
  EXPECT_THROW(gpu.deform(P, corner_free), SolverError);
  EXPECT_EQ((gpu.vertices() - rest).cwiseAbs().maxCoeff(), 0.0);
  const DeformResult good = gpu.deform(rest_control_points(s.L) * 0.9, {});
  EXPECT_THROW(gpu.deform(P, corner_free), SolverError);
  EXPECT_EQ((gpu.vertices() - good.vertices).cwiseAbs().maxCoeff(), 0.0);
  Deformer cpu(s.V, s.F, s.L);
  expect_close(gpu.deform(P, {}), cpu.deform(P, {}), s.F, s.L, P);
}

// Frames of several threads on one deformer: each gets its own vertices.
TEST_P(VulkanP, ThreadsGetTheirOwnFrames) {
  Scene s = sphere(3, 3, {5, 5, 5});
  auto gpu_ptr = make(s.V, s.F, s.L);
  vulkan::VulkanDeformer& gpu = *gpu_ptr;
  const RowMatrixX3d P[2] = {edit(s.L), 1.1 * edit(s.L)};
  CorrectionOptions o[2];
  o[1].preserve_volume = false;
  const RowMatrixX3d want[2] = {gpu.deform(P[0], o[0]).vertices, gpu.deform(P[1], o[1]).vertices};
  int bad[2] = {0, 0};
  auto run = [&](int i) {
    for (int f = 0; f < 300; ++f) {
      if ((gpu.deform(P[i], o[i]).vertices - want[i]).cwiseAbs().maxCoeff() != 0.0) ++bad[i];
      if (!(gpu.last_timings().host_total > 0)) ++bad[i];
    }
  };
  std::thread a(run, 0), b(run, 1);
  a.join();
  b.join();
  EXPECT_EQ(bad[0], 0);
  EXPECT_EQ(bad[1], 0);
}

// The multiresolution frame on the device (multires.comp) against MultiresFFD under an
// affine map x -> A x + t of a bumpy sphere's decomposition: the FFD of the mapped rest
// control points reproduces it exactly (J = A at every foot point), and the CPU gives
// S' = A S + t, S'_u = A S_u, S'_v = A S_v. The bound is the Python tests'
// (gpu_bounds.multires_bounds) with the Jacobian columns' error of NormalsOfAnAffineMap
// (worst cases of the basis sums for clamped uniform knots), the value's error
// eS = 1.01 (3 R eB + (3K + 4) u R), and per vertex
//   e_su = sum_a |S_u,a| (e + 3 u (|A_a| + e)) + u |S_u| sum_a |A_a|   (S_v alike),
//   e_c = e_su |S'_v| + |S'_u| e_sv + e_su e_sv + 4 u S'_u~ S'_v~,  e_N = 2 e_c / |c| + 4 u,
//   e_p = eS + |d| e_N + 3 u |d| + u (|S' - o| + |d|),
//   e_f = |a| e_su + |b| e_sv + |g| e_N + 4 u (|a| S'_u~ + |b| S'_v~ + |g|),
//   e_n = e_fu |F_v| + |F_u| e_fv + e_fu e_fv + 4 u F_u~ F_v~,  angle <= asin(e_n / |n|) + 4 u.
TEST_P(VulkanP, MultiresFrameOfAnAffineMap) {
  Scene s = sphere(3, 3, {5, 5, 5});
  s.V = vpffd::test::bumpy(3).V;  // the same icosphere(3), with bumps
  auto mr = std::make_shared<Multires>(decompose(s.V, s.F, 3.0));
  vulkan::VulkanMultires gpu(mr, s.L, "", GetParam());
  EXPECT_EQ(gpu.precision(), GetParam());
  const MultiresFFD& cpu = gpu.cpu();
  Eigen::Matrix3d A;
  A << 1.1, 0.2, 0.0, 0.0, 0.9, 0.1, 0.1, 0.0, 1.2;
  const Vector3d t(0.05, -0.1, 0.02);
  const RowMatrixX3d P = (rest_control_points(s.L) * A.transpose()).rowwise() + t.transpose();
  const MultiresFrame g = gpu.deform(P), c = cpu.deform(P);
  ASSERT_EQ(g.vertices.rows(), s.V.rows());
  ASSERT_EQ(g.normals.rows(), s.V.rows());
  const MultiresFrame g2 = gpu.deform(P);  // a frame depends only on its control points
  EXPECT_TRUE(g2.vertices == g.vertices && g2.normals == g.normals);

  const double u = std::ldexp(1.0, -24);
  const int d = 3, K = d + 1;
  const double h = (s.L.box_max[0] - s.L.box_min[0]) / (5 - d), gs = 1 / h;
  const Vector3d o = 0.5 * (s.L.box_min + s.L.box_max);
  const double R = (P.rowwise() - o.transpose()).rowwise().norm().maxCoeff();
  const double eB = u * (1 + 2 * d) + 1e-9, eD = gs * (u * (2 * d + 4 * d * (d - 1)) + 1e-9), S = 2 * d * gs;
  const double e = 1.01 * (R * (eD + 2 * S * eB) + (3 * K + 3) * u * R * S + 2 * u * R * S);
  const double eS = 1.01 * (3 * R * eB + (3 * K + 4) * u * R);
  const Vector3d cn = A.colwise().norm().transpose();
  const double diag = (s.L.box_max - s.L.box_min).norm();
  double worst_p = 0, worst_n = 0;
  for (Index v = 0; v < s.V.rows(); ++v) {
    for (int a = 0; a < 3; ++a) ASSERT_TRUE(mr->foot[a][v] >= s.L.box_min[a] && mr->foot[a][v] <= s.L.box_max[a]);
    auto image = [&](const Vector3d& tv, Vector3d& img) {
      img = A * tv;
      double err = u * tv.norm() * cn.sum();
      for (int a = 0; a < 3; ++a) err += std::abs(tv[a]) * (e + 3 * u * (cn[a] + e));
      return 1.01 * err;
    };
    Vector3d su1, sv1;
    const double e_su = image(mr->tangent_u(v), su1), e_sv = image(mr->tangent_v(v), sv1);
    const Vector3d cr = su1.cross(sv1), ns = cr.normalized();
    const double e_c = e_su * sv1.norm() + su1.norm() * e_sv + e_su * e_sv +
                       4 * u * (su1.norm() + e_su) * (sv1.norm() + e_sv);
    const double e_N = 2 * e_c / cr.norm() + 4 * u;
    const double ad = std::abs(mr->d[v]);
    const Vector3d S1 = A * mr->foot_point(v) + t;
    const double e_p = eS + ad * e_N + 3 * u * ad + u * ((S1 - o).norm() + ad);
    const NormalCoefficients k = mr->coefficients(v);
    Vector3d f[2];
    double ef[2];
    for (int j = 0; j < 2; ++j) {
      const double a = k[3 * j], b = k[3 * j + 1], gg = k[3 * j + 2];
      f[j] = a * su1 + b * sv1 + gg * ns;
      ef[j] = 1.01 * (std::abs(a) * e_su + std::abs(b) * e_sv + std::abs(gg) * e_N +
                      4 * u * (std::abs(a) * (su1.norm() + e_su) + std::abs(b) * (sv1.norm() + e_sv) + std::abs(gg)));
    }
    const double e_n = ef[0] * f[1].norm() + f[0].norm() * ef[1] + ef[0] * ef[1] +
                       4 * u * (f[0].norm() + ef[0]) * (f[1].norm() + ef[1]);
    const double bound_n = std::asin(std::min(1.0, e_n / f[0].cross(f[1]).norm())) + 4 * u + std::ldexp(1.0, -40);
    const double bound_p = e_p + 1e-12 * diag;  // the CPU's own rounding (test_multires: 1e-12)
    const Vector3d gn = g.normals.row(v).transpose(), cnv = c.normals.row(v).transpose();
    EXPECT_LE((g.vertices.row(v) - c.vertices.row(v)).norm(), bound_p) << "vertex " << v;
    EXPECT_LE(std::atan2(gn.cross(cnv).norm(), gn.dot(cnv)), bound_n) << "vertex " << v;
    EXPECT_NEAR(gn.norm(), 1.0, 1e-6);
    worst_p = std::max(worst_p, bound_p / diag);
    worst_n = std::max(worst_n, bound_n);
  }
  // The bounds are tight enough to mean something: with the basis sums' global worst
  // cases they are about 1.3x the 0.01 degree and 1e-5 of the diagonal (the
  // Python tests' per-vertex sums prove 0.01 degree for a moderate edit).
  EXPECT_LT(worst_n, 0.02 / 180 * std::acos(-1.0));
  EXPECT_LT(worst_p, 2e-5);
  // Bad input: the CPU's checks and messages, and the device's range.
  EXPECT_THROW(gpu.deform(P.topRows(P.rows() - 1)), InvalidInputError);
  RowMatrixX3d bad = P;
  bad(2, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(gpu.deform(bad), InvalidInputError);
  bad(2, 1) = 1e300;
  EXPECT_THROW(gpu.deform(bad), InvalidInputError);
}

// A frame after a VulkanDeformer's in one submission (VulkanMultires::deform with a
// Deformer). Device arithmetic is deterministic (fixed reduction shapes), so what can
// be compared bit for bit is: the correction (the Deformer's frame alone), the base
// vertices of volume "base" (its vertices), and, without a correction, the whole
// reconstruction (the control points on the device are the same floats as those the
// standalone frame uploads: fl((P - o) / scale) on both sides).
TEST_P(VulkanP, MultiresAfterDeformerFrame) {
  Scene s = sphere(3, 3, {5, 5, 5});
  s.V = vpffd::test::bumpy(3).V;  // the same icosphere(3), with bumps
  auto mr = std::make_shared<Multires>(decompose(s.V, s.F, 3.0));
  vulkan::VulkanMultires gpu(mr, s.L, "", GetParam());
  vulkan::VulkanDeformer base(mr->base, s.F, s.L, OutsidePolicy::Error, "", GetParam());
  vulkan::VulkanDeformer fine(s.V, s.F, s.L, OutsidePolicy::Error, "", GetParam());
  // A 20 % stretch along x (a volume the correction takes back: large offsets) and a wave.
  RowMatrixX3d P = rest_control_points(s.L);
  for (Index c = 0; c < P.rows(); ++c) P(c, 0) = 1.2 * P(c, 0) + 0.1 * std::sin(3 * P(c, 1)) * P(c, 2);
  CorrectionOptions plain;
  plain.preserve_volume = false;
  const vulkan::MultiresDeviceFrame f0 = gpu.deform(base, P, plain);
  const MultiresFrame g0 = gpu.deform(P);
  EXPECT_TRUE(f0.frame.vertices == g0.vertices && f0.frame.normals == g0.normals);
  EXPECT_TRUE(f0.base_vertices == base.deform(P, plain).vertices);

  const CorrectionOptions opt;  // volume correction along x, y, z
  const vulkan::MultiresDeviceFrame fb = gpu.deform(base, P, opt);
  const DeformResult rb = base.deform(P, opt);
  EXPECT_TRUE(fb.correction.control_points == rb.control_points);
  EXPECT_TRUE(fb.base_vertices == rb.vertices);
  EXPECT_GT((fb.correction.offsets).cwiseAbs().maxCoeff(), 0.0);
  // The reconstruction follows the corrected control points: the standalone frame of
  // P + offsets differs from it only by the rounding of the control points (the device
  // rounds P, then the sum; the host the sum once): a few u = 6e-8 of the box, against
  // the offsets' effect (here a few percent of the box), so 1e-3 of that effect is loose.
  const double diag = (s.L.box_max - s.L.box_min).norm();
  const MultiresFrame gb = gpu.deform(rb.control_points);
  const double by_offsets = (fb.frame.vertices - g0.vertices).rowwise().norm().maxCoeff();
  EXPECT_GT(by_offsets, 1e-5 * diag);
  EXPECT_LT((fb.frame.vertices - gb.vertices).rowwise().norm().maxCoeff(), 1e-3 * by_offsets);

  const vulkan::MultiresDeviceFrame ff = gpu.deform(fine, P, opt, &base);
  const DeformResult rf = fine.deform(P, opt);
  EXPECT_TRUE(ff.correction.control_points == rf.control_points);
  EXPECT_EQ(ff.correction.vertices.rows(), 0);
  // The base Deformer ran the FFD of the corrected control points in the submission:
  // its device vertices are the frame's base vertices.
  EXPECT_TRUE(base.vertices() == ff.base_vertices);
  const RowMatrixX3d cpu_base = base.cpu().ffd(rf.control_points);
  EXPECT_LT((ff.base_vertices - cpu_base).rowwise().norm().maxCoeff(), 1e-4 * diag);
  const MultiresFrame gf = gpu.deform(rf.control_points);
  EXPECT_LT((ff.frame.vertices - gf.vertices).rowwise().norm().maxCoeff(),
            1e-3 * (gf.vertices - g0.vertices).rowwise().norm().maxCoeff());

  // Deformers that cannot feed this frame.
  EXPECT_THROW(gpu.deform(base, P, opt, &base), InvalidInputError);
  Lattice L2 = s.L;
  L2.box_max *= 1.5;
  vulkan::VulkanDeformer other(mr->base, s.F, L2, OutsidePolicy::Error, "", GetParam());
  EXPECT_THROW(gpu.deform(other, P, opt), InvalidInputError);
  EXPECT_THROW(gpu.deform(fine, P, opt, &other), InvalidInputError);
  if (GetParam() == vulkan::Precision::Float64) {
    vulkan::VulkanDeformer other_prec(mr->base, s.F, s.L, OutsidePolicy::Error, "", vulkan::Precision::FloatFloat);
    EXPECT_THROW(gpu.deform(other_prec, P, opt), InvalidInputError);
  }
  // The correction's own errors pass through, and the frame works afterwards.
  EXPECT_THROW(gpu.deform(base, P.topRows(3), opt), InvalidInputError);
  EXPECT_TRUE(gpu.deform(base, P, plain).frame.vertices == g0.vertices);
}

// Parts on the device: two spheres of different sizes in one lattice, each keeping its
// own volume under an edit that changes them unevenly. Each part's volume error is
// bounded by the whole mesh's corrected-volume bound (a sum over the part's vertices
// of the same non-negative terms: tests/python/test_vulkan_parts.py), the vertices by
// the vertex bound against the CPU frame with the same parts.
TEST_P(VulkanP, PartsKeepTheirOwnVolumes) {
  const TriMesh m = icosphere(2);
  const Index nv = m.V.rows(), nf = m.F.rows();
  RowMatrixX3d V(2 * nv, 3);
  RowMatrixX3i F(2 * nf, 3);
  V.topRows(nv) = m.V;
  V.bottomRows(nv) = 0.7 * m.V;
  V.bottomRows(nv).col(0).array() += 2.5;
  F.topRows(nf) = m.F;
  F.bottomRows(nf) = m.F.array() + static_cast<int>(nv);
  const Lattice L = test::lattice_around(V, {8, 5, 5}, 3);
  const MeshParts parts = parts_from_components(F, V.rows());
  ASSERT_EQ(parts.count, 2);
  Deformer cpu(V, F, L, OutsidePolicy::Error, 0, &parts);
  vulkan::VulkanDeformer gpu(V, F, L, OutsidePolicy::Error, "", GetParam(), &parts);
  EXPECT_EQ(gpu.rest_part_volumes().size(), 2);
  RowMatrixX3d P = edit(L);
  for (Index c = 0; c < P.rows(); ++c)
    if (rest_control_points(L)(c, 0) < L.box_min[0] + 0.3 * (L.box_max[0] - L.box_min[0])) P(c, 1) *= 0.8;
  for (const char* axes : {"xyz", "zx"}) {
    SCOPED_TRACE(axes);
    CorrectionOptions o;
    o.axes = parse_axes(axes);
    const DeformResult c = cpu.deform(P, o), g = gpu.deform(P, o);
    expect_close(g, c, F, L, P);
    const Bounds b = bounds(c, F, L, P);
    ASSERT_EQ(g.part_volumes.size(), 2);
    ASSERT_EQ(g.part_targets.size(), 2);
    for (int k = 0; k < 2; ++k) {
      EXPECT_EQ(g.part_targets[k], gpu.rest_part_volumes()[k]);
      EXPECT_LE(std::abs(g.part_volumes[k] - g.part_targets[k]), b.corrected_volume);
      // The edit did change the part (the check above is not vacuous).
      EXPECT_GT(std::abs(g.part_volumes_before[k] - g.part_targets[k]), 100 * b.corrected_volume);
    }
  }
}

// Periodic lattices, every seam, on a bumpy sphere across the box's x = max face (its
// foot points wrapped on the host): the frame takes the distinct control points, and
// the parts that can be compared bit for bit are (as MultiresAfterDeformerFrame): without
// a correction, the reconstruction after a periodic Deformer's frame equals the
// standalone one (the Deformer expands the distinct points to the same floats as this
// frame's host); with one, the reconstruction follows the corrected control points up
// to their rounding, which needs each tied copy to get its distinct point's offset. The
// match with the CPU within derived bounds is tests/python/test_multires_vulkan_periodic.py.
TEST_P(VulkanP, MultiresPeriodicLattices) {
  const TriMesh m = vpffd::test::bumpy(3);
  const RowMatrixX3d V = (0.3 * m.V).rowwise() + Eigen::RowVector3d(1.85, 0.0, 0.0);
  auto mr = std::make_shared<Multires>(decompose(V, m.F, 3.0));
  for (Seam seam : {Seam::Shift, Seam::Closed, Seam::Twist}) {
    SCOPED_TRACE(int(seam));
    const Lattice L = make_lattice(Vector3d(-1.0, -0.5, -0.4), Vector3d(2.0, 0.5, 0.4), {7, 5, 4}, {3, 3, 3},
                                   {seam, Seam::None, Seam::None});
    vulkan::VulkanMultires gpu(mr, L, "", GetParam());
    vulkan::VulkanDeformer base(mr->base, m.F, L, OutsidePolicy::Error, "", GetParam());
    const Ties& ties = gpu.cpu().ties();
    ASSERT_LT(gpu.cpu().n_control_points(), L.n_control_points());
    EXPECT_THROW(gpu.deform(rest_control_points(L)), InvalidInputError);  // the extended points: refused
    RowMatrixX3d P = restrict_points(ties, rest_control_points(L));
    for (Index c = 0; c < P.rows(); ++c) {
      P(c, 1) += 0.05 * std::sin(2.0 * P(c, 0));
      P(c, 2) *= 1.0 + 0.1 * std::cos(P(c, 0));
    }
    CorrectionOptions plain;
    plain.preserve_volume = false;
    const vulkan::MultiresDeviceFrame f0 = gpu.deform(base, P, plain);
    const MultiresFrame g0 = gpu.deform(P);
    EXPECT_TRUE(f0.frame.vertices == g0.vertices && f0.frame.normals == g0.normals);
    EXPECT_TRUE(f0.base_vertices == base.deform(P, plain).vertices);

    CorrectionOptions opt;
    opt.axes = parse_axes("zy");
    const vulkan::MultiresDeviceFrame fb = gpu.deform(base, P, opt);
    const DeformResult rb = base.deform(P, opt);
    EXPECT_TRUE(fb.correction.control_points == rb.control_points);
    const MultiresFrame gb = gpu.deform(rb.control_points);
    const double by_offsets = (fb.frame.vertices - g0.vertices).rowwise().norm().maxCoeff();
    const double diag = (L.box_max - L.box_min).norm();
    EXPECT_GT(by_offsets, 1e-5 * diag);
    // The device rounds P, then the sum; the host the sum once: a few u = 6e-8 of the
    // box, so 1e-3 of the offsets' effect is loose.
    EXPECT_LT((fb.frame.vertices - gb.vertices).rowwise().norm().maxCoeff(), 1e-3 * by_offsets);
  }
}

// Periodic lattices, every seam: a sphere across the box's x = max face (wrapped on
// the device), plain, corrected and constrained frames against the CPU within the
// bounds above (their periodic terms included); the offsets are the distinct points'.
TEST_P(VulkanP, PeriodicLatticesMatchCpu) {
  const TriMesh m = icosphere(3);
  const RowMatrixX3d V = (0.3 * m.V).rowwise() + Eigen::RowVector3d(1.85, 0.0, 0.0);
  for (Seam seam : {Seam::Shift, Seam::Closed, Seam::Twist}) {
    SCOPED_TRACE(int(seam));
    const Lattice L = make_lattice(Vector3d(-1.0, -0.5, -0.4), Vector3d(2.0, 0.5, 0.4), {7, 5, 4}, {3, 3, 3},
                                   {seam, Seam::None, Seam::None});
    Deformer cpu(V, m.F, L);
    auto gpu = make(V, m.F, L);
    // A smooth edit of the distinct rest points.
    RowMatrixX3d P = restrict_points(cpu.ties(), rest_control_points(L));
    ASSERT_EQ(P.rows(), cpu.n_control_points());
    for (Index c = 0; c < P.rows(); ++c) {
      P(c, 1) += 0.05 * std::sin(2.0 * P(c, 0));
      P(c, 2) *= 1.0 + 0.1 * std::cos(P(c, 0));
    }
    CorrectionOptions plain, kept, cons;
    plain.preserve_volume = false;
    kept.axes = parse_axes("zx");
    kept.rounds = 2;
    PointConstraint pc;
    pc.vertex = 0;
    for (Index v = 1; v < V.rows(); ++v)
      if (V(v, 0) < V(pc.vertex, 0)) pc.vertex = v;  // inside the box (a shift seam needs that)
    pc.target = cpu.ffd(P).row(pc.vertex).transpose() + Vector3d(0.01, 0.02, -0.01);
    cons.constraints = {pc};
    for (const CorrectionOptions* o : {&plain, &kept, &cons}) {
      const DeformResult c = cpu.deform(P, *o), g = gpu->deform(P, *o);
      ASSERT_EQ(g.offsets.rows(), P.rows());
      expect_close(g, c, m.F, L, P);
      expect_offsets_explain_vertices(cpu, g, c, L, P);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Precisions, VulkanP,
                         ::testing::Values(vulkan::Precision::Float64, vulkan::Precision::FloatFloat),
                         [](const auto& info) {
                           return info.param == vulkan::Precision::Float64 ? std::string("Float64")
                                                                            : std::string("FloatFloat");
                         });

TEST(Vulkan, PrecisionChoice) {
  EXPECT_EQ(vulkan::parse_precision("float-float"), vulkan::Precision::FloatFloat);
  EXPECT_STREQ(vulkan::precision_name(vulkan::Precision::Float64), "float64");
  EXPECT_THROW(vulkan::parse_precision("double"), InvalidInputError);
  REQUIRE_DEVICE();
  Scene s = sphere(1, 2, {3, 3, 3});
  vulkan::VulkanDeformer gpu(s.V, s.F, s.L);
  EXPECT_EQ(gpu.precision(), gpu.device().float64 ? vulkan::Precision::Float64 : vulkan::Precision::FloatFloat);
}

TEST(Vulkan, BadDeviceNameRaises) {
  Scene s = sphere(1, 2, {3, 3, 3});
  EXPECT_THROW(vulkan::VulkanDeformer(s.V, s.F, s.L, OutsidePolicy::Error, "no-such-device-xyz"),
               BackendUnavailableError);
}

}  // namespace
#endif
