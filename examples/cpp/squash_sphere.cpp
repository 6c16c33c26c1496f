// Squashes an icosphere to half its height and restores its volume by moving
// the control points horizontally only (the paper's bouncing-ball correction).
#include <cstdio>

#include "vpffd/vpffd.h"

int main() {
  const vpffd::TriMesh sphere = vpffd::icosphere(4);
  const vpffd::Lattice lattice =
      vpffd::make_lattice({-1.1, -1.1, -1.1}, {1.1, 1.1, 1.1}, {6, 6, 6}, {3, 3, 3});
  vpffd::Deformer deformer(sphere.V, sphere.F, lattice);

  const vpffd::RowMatrixX3d squashed =
      vpffd::scale(vpffd::rest_control_points(lattice), {1.0, 1.0, 0.5}, {0.0, 0.0, 0.0});
  vpffd::CorrectionOptions options;
  options.axes = vpffd::parse_axes("xy");
  const vpffd::DeformResult r = deformer.deform(squashed, options);

  std::printf("rest volume %.12f, plain FFD %.12f, preserved %.12f\n", deformer.rest_volume(), r.volume_before,
              r.volume);
  const double err = std::abs(r.volume - deformer.rest_volume()) / deformer.rest_volume();
  return err < 1e-12 ? 0 : 1;
}
