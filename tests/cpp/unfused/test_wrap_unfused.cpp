// Built on its own with -ffp-contract=off (tests/CMakeLists.txt): a baseline x86-64
// build never fuses a multiply-add, and this one stands for it on any machine. An
// inline function compiled both ways in one binary would be one definition, so
// these tests are a binary of their own.

#include <gtest/gtest.h>

#include <cmath>

#include "vpffd/lattice/lattice.h"
#include "vpffd/lattice/periodic.h"

namespace vpffd {
namespace {

#if defined(__SIZEOF_FLOAT128__)
// x - turns * ext exactly (a 53 x 53-bit product and a difference of two numbers of
// like size fit in __float128's 113 bits), rounded once to double.
double exact_remainder(double x, double turns, double ext) {
  return static_cast<double>(static_cast<__float128>(x) - static_cast<__float128>(turns) * static_cast<__float128>(ext));
}
#endif

TEST(Unfused, WrapRoundsOnceWithoutContraction) {
#if !defined(__SIZEOF_FLOAT128__)
  GTEST_SKIP() << "no __float128 for the exact reference";
#else
  // A box whose bounds and extent have full mantissas, periodic along x: a point k
  // boxes away wraps to the exact x - turns * ext rounded once, whether or not the
  // compiler fuses multiply-adds (this file: never).
  const Lattice L = make_lattice(Vector3d(-0.37126518374, 0, 0), Vector3d(1.36770103719, 1, 1), {6, 4, 4}, {3, 3, 3},
                                 {Seam::Shift, Seam::None, Seam::None});
  const double lo = L.box_min[0], ext = L.box_max[0] - L.box_min[0];
  int compared = 0, product_rounds = 0;
  for (double k = 1; k < std::ldexp(1.0, 45); k *= 1.37) {
    for (double r : {0.0123456789, 0.5, 0.987654321}) {
      const double x = lo + (std::floor(k) + r) * ext;
      const double turns = std::floor((x - lo) / ext);
      const double want = exact_remainder(x, turns, ext);
      if (!(want >= lo && want < L.box_max[0])) continue;  // the wrap's corrections apply there
      volatile double product = turns * ext;               // what an unfused build subtracts
      product_rounds += (x - product) != want;
      EXPECT_EQ(wrap_point(L, Vector3d(x, 0.5, 0.5))[0], want) << "x " << x << " turns " << turns;
      ++compared;
    }
  }
  EXPECT_GT(compared, 200);
  // The test has teeth: the unfused formula rounds differently for many of the points.
  EXPECT_GT(product_rounds, compared / 4) << compared;
#endif
}

}  // namespace
}  // namespace vpffd
