// One deformer shared by threads: frames on some, moves of the rest mesh on another.
// Every frame must be, bit for bit, the frame of one of the rest states it could have
// seen (before or after any move), never a mix and never a crash. The references are
// the same deformer's frames taken serially in each state (moves are bit-exact against
// a fresh deformer: test_reorder, test_vulkan), so any difference is a race.

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "helpers.h"
#include "vpffd/vpffd.h"

#ifdef VPFFD_HAS_VULKAN
#include "vpffd/backend/vulkan.h"
#endif

namespace threads_test {

using namespace vpffd;

bool same(const RowMatrixX3d& a, const RowMatrixX3d& b) {
  return a.rows() == b.rows() && std::memcmp(a.data(), b.data(), sizeof(double) * a.size()) == 0;
}
bool same(const VectorXd& a, const VectorXd& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), sizeof(double) * a.size()) == 0;
}

/// What one frame thread computes, for one rest state.
struct Frames {
  RowMatrixX3d kept, plain, ffd;
  VectorXd det;
  double volume = 0;
};

struct Stress {
  RowMatrixX3d V;
  RowMatrixX3i F;
  Lattice L;
  RowMatrixX3d P;
  RowMatrixX3d X1;  // the second rest state (positions)
  RowMatrixX3d O1;  // and as an offset from V
};

Stress scene() {
  Stress s;
  const TriMesh m = icosphere(4);
  s.V = 0.6 * m.V;
  s.F = m.F;
  s.L = make_lattice(Vector3d(-1, -1, -1), Vector3d(1, 1, 1), {6, 6, 6}, {3, 3, 3});
  s.P = test::squashed(s.L, 0.7);
  s.O1 = RowMatrixX3d(1, 3);
  s.O1 << 0.13, -0.21, 0.08;  // crosses cells: the processing order changes
  s.X1 = s.V.rowwise() + s.O1.row(0);
  return s;
}

CorrectionOptions kept_options() {
  CorrectionOptions o;
  o.threads = 1;
  return o;
}
CorrectionOptions plain_options() {
  CorrectionOptions o;
  o.preserve_volume = false;
  o.threads = 1;
  return o;
}

/// Runs `frame_threads` threads of `frame` against one thread alternating `move(0)` and
/// `move(1)`: each frame thread makes at least `frames` frames and goes on until the
/// mover has made `min_moves` moves (or a minute has passed); returns the number of
/// frames that matched neither state and the number of moves made (`moves`).
int run_stress(int frame_threads, int frames, int min_moves, const std::function<int()>& frame,
               const std::function<void(int)>& move, int* moves) {
  using Clock = std::chrono::steady_clock;
  const auto deadline = Clock::now() + std::chrono::seconds(60);
  std::atomic<int> bad{0}, running{frame_threads}, n{0};
  std::vector<std::thread> pool;
  for (int t = 0; t < frame_threads; ++t)
    pool.emplace_back([&] {
      for (int i = 0; (i < frames || n < min_moves) && Clock::now() < deadline; ++i) bad += frame();
      --running;
    });
  std::thread mover([&] {
    while (running > 0) {
      move(n % 2);
      ++n;
    }
  });
  for (std::thread& t : pool) t.join();
  mover.join();
  *moves = n;
  return bad;
}

class CpuThreads : public ::testing::TestWithParam<std::string> {};

TEST_P(CpuThreads, FramesSeeOneRestState) {
  const Stress s = scene();
  const bool offsets = GetParam() == "offsets";
  Deformer d(s.V, s.F, s.L);
  auto move = [&](int state) {
    if (offsets)
      d.set_rest_offsets(state ? s.O1 : RowMatrixX3d(RowMatrixX3d::Zero(1, 3)), 1);
    else
      d.set_rest_vertices(state ? s.X1 : s.V, 1);
  };
  Frames ref[2];
  for (int state : {1, 0}) {  // state 0 last: the stress starts there
    move(state);
    Frames& f = ref[state];
    const DeformResult r = d.deform(s.P, kept_options());
    f.kept = r.vertices;
    f.volume = r.volume;
    f.plain = d.deform(s.P, plain_options()).vertices;
    f.ffd = d.ffd(s.P, 1);
    f.det = d.jacobian_determinants(s.P, 1);
  }
  ASSERT_FALSE(same(ref[0].kept, ref[1].kept));
  ASSERT_FALSE(same(ref[0].ffd, ref[1].ffd));
  std::atomic<int> kind{0};
  auto frame = [&]() -> int {
    switch (kind++ % 4) {
      case 0: {
        const DeformResult r = d.deform(s.P, kept_options());
        return !((same(r.vertices, ref[0].kept) && r.volume == ref[0].volume) ||
                 (same(r.vertices, ref[1].kept) && r.volume == ref[1].volume));
      }
      case 1: {
        const RowMatrixX3d X = d.deform(s.P, plain_options()).vertices;
        return !(same(X, ref[0].plain) || same(X, ref[1].plain));
      }
      case 2: {
        const RowMatrixX3d X = d.ffd(s.P, 1);
        return !(same(X, ref[0].ffd) || same(X, ref[1].ffd));
      }
      default: {
        const VectorXd det = d.jacobian_determinants(s.P, 1);
        return !(same(det, ref[0].det) || same(det, ref[1].det));
      }
    }
  };
  int moves = 0;
  EXPECT_EQ(run_stress(3, 40, 20, frame, move, &moves), 0);
  EXPECT_GE(moves, 20);
}

INSTANTIATE_TEST_SUITE_P(Moves, CpuThreads, ::testing::Values("positions", "offsets"));

// A rest state held by a caller (as a frame in flight holds it) stays what it was while
// the deformer moves on: its buffers are not recycled into later states, and a frame
// run on it later is the frame of that state, bit for bit. States nobody holds are
// recycled; the frames of the states built in their buffers are a fresh deformer's.
TEST(RestStates, HeldStateOutlivesMoves) {
  const Stress s = scene();
  Deformer d(s.V, s.F, s.L);
  const CorrectionOptions opt = kept_options();
  const std::shared_ptr<const RestState> held = d.rest_state();
  const DeformResult before = frame::run_frame(d.topology(), *held, s.P, opt, nullptr);
  const RowMatrixX3d half = 0.5 * s.O1;
  const RowMatrixX3d X2 = s.V.rowwise() - half.row(0);
  for (int k = 0; k < 8; ++k) {  // positions and offsets, back and forth
    if (k % 2 == 0)
      d.set_rest_vertices(k % 4 == 0 ? s.X1 : X2, 1);
    else
      d.set_rest_offsets(k % 4 == 1 ? half : RowMatrixX3d(-half), 1);
  }
  EXPECT_NE(d.rest_state(), held);
  EXPECT_TRUE(same(*held->V, s.V));
  const DeformResult again = frame::run_frame(d.topology(), *held, s.P, opt, nullptr);
  EXPECT_TRUE(same(again.vertices, before.vertices));
  EXPECT_EQ(again.volume, before.volume);
  // The last move: offsets -O1/2 from the base X2 (set by the set_rest_vertices before
  // it). Frames that keep the volume aim at the base's rest volume there (rounding
  // apart, the fresh one's): compared on plain frames.
  const RowMatrixX3d last = X2.rowwise() - half.row(0);
  Deformer fresh(last, s.F, s.L);
  const CorrectionOptions plain = plain_options();
  EXPECT_TRUE(same(d.deform(s.P, plain).vertices, fresh.deform(s.P, plain).vertices));
  EXPECT_TRUE(same(d.ffd(s.P, 1), fresh.ffd(s.P, 1)));
}

// A move that is refused (a vertex outside the box) changes nothing, under threads too.
TEST(CpuThreadsRefused, RefusedMovesLeaveFramesAlone) {
  const Stress s = scene();
  Deformer d(s.V, s.F, s.L);
  const RowMatrixX3d ref = d.deform(s.P, kept_options()).vertices;
  RowMatrixX3d far = s.V;
  far(7, 0) = 5.0;
  auto move = [&](int) {
    try {
      d.set_rest_vertices(far, 1);
    } catch (const InvalidInputError&) {
    }
  };
  auto frame = [&]() -> int { return !same(d.deform(s.P, kept_options()).vertices, ref); };
  int moves = 0;
  EXPECT_EQ(run_stress(2, 30, 20, frame, move, &moves), 0);
  EXPECT_GE(moves, 20);
}

#ifdef VPFFD_HAS_VULKAN
bool have_device() {
  for (const auto& dev : vulkan::devices())
    if (dev.suitable) return true;
  return false;
}

class VulkanThreads : public ::testing::TestWithParam<std::string> {};

TEST_P(VulkanThreads, FramesSeeOneRestState) {
  if (!have_device()) GTEST_SKIP() << "no suitable Vulkan device";
  const Stress s = scene();
  const bool offsets = GetParam() == "offsets";
  vulkan::VulkanDeformer d(s.V, s.F, s.L);
  auto move = [&](int state) {
    if (offsets)
      d.set_rest_offsets(state ? s.O1 : RowMatrixX3d(RowMatrixX3d::Zero(1, 3)));
    else
      d.set_rest_vertices(state ? s.X1 : s.V);
  };
  Frames ref[2];
  for (int state : {1, 0}) {
    move(state);
    const DeformResult r = d.deform(s.P, kept_options());
    ref[state].kept = r.vertices;
    ref[state].volume = r.volume;
    ref[state].plain = d.deform(s.P, plain_options()).vertices;
  }
  ASSERT_FALSE(same(ref[0].kept, ref[1].kept));
  std::atomic<int> kind{0};
  auto frame = [&]() -> int {
    if (kind++ % 2 == 0) {
      const DeformResult r = d.deform(s.P, kept_options());
      return !((same(r.vertices, ref[0].kept) && r.volume == ref[0].volume) ||
               (same(r.vertices, ref[1].kept) && r.volume == ref[1].volume));
    }
    const RowMatrixX3d X = d.deform(s.P, plain_options()).vertices;
    return !(same(X, ref[0].plain) || same(X, ref[1].plain));
  };
  int moves = 0;
  EXPECT_EQ(run_stress(3, 12, 10, frame, move, &moves), 0);
  EXPECT_GE(moves, 10);
}

INSTANTIATE_TEST_SUITE_P(Moves, VulkanThreads, ::testing::Values("positions", "offsets"));
#endif

}  // namespace threads_test
