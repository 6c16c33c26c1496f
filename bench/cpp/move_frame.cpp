// N rounds of (move the rest mesh, xyz frame) on one thread, for counts under valgrind's
// cachegrind (run it with N = 1 and N = 4 and take the difference / 3: construction
// cancels). Each move changes the processing order, so each frame first brings the
// vertex fans to the new order: the case where rest states share least.
//
//   move_frame N [ICOSPHERE_LEVEL]
#include <cstdio>
#include <cstdlib>
#include "vpffd/vpffd.h"
using namespace vpffd;
int main(int argc, char** argv) {
  const int n = std::atoi(argv[1]);
  const TriMesh m = icosphere(argc > 2 ? std::atoi(argv[2]) : 6);
  const RowMatrixX3d V = 0.6 * m.V;
  const Lattice L = make_lattice(Vector3d(-1, -1, -1), Vector3d(1, 1, 1), {10, 10, 10}, {3, 3, 3});
  Deformer d(V, m.F, L);
  RowMatrixX3d P = rest_control_points(L);
  for (Index i = 0; i < P.rows(); ++i) P(i, 2) *= 0.8;
  RowMatrixX3d X[2] = {(V.array() + 0.01).matrix(), (V.array() - 0.01).matrix()};
  CorrectionOptions opt;
  opt.threads = 1;
  double s = 0;
  for (int k = 0; k < n; ++k) {
    d.set_rest_vertices(X[k % 2], 1);
    s += d.deform(P, opt).volume;
  }
  std::printf("%d rounds, %.17g\n", n, s);
}
