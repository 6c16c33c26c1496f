#version 450
// The rest vertex normals n0 that normals.comp maps, from the rest positions on the
// device: per slot the sum of its faces' cross products (x1 - x0) x (x2 - x0), the
// area-weighted normal of ffd/normals.h's vertex_normals, over the vertex-face lists
// in their fixed order (so the result does not depend on scheduling). Recorded by the
// first frame with normals after construction or a move, in that frame's submission
// (after the move's embedding, which writes the rest positions): a moved object's
// normals then cost no host pass over the mesh and no upload.
//
// Edges, products and sums are reals (float64, or float-float with relative rounding
// U_SUM per operation), so the one float32 rounding per component at the end is what
// the host's double normal rounded to float32 had (tests/python/gpu_bounds.py,
// normal_angle_bound: rest_normal_errors). normals.comp needs only n0's direction, so
// the sum is divided by its largest component before that rounding (no normalisation:
// that would add a square root's and a division's rounding); a zero sum gives zero, as
// the CPU's normalized_or_zero.
#include "common.glsl"
layout(local_size_x = VPFFD_GROUP) in;

void main() {
  const uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
  for (uint v = gl_GlobalInvocationID.x; v < uint(NVERT); v += stride) {
    real n[3] = real[3](r_zero(), r_zero(), r_zero());
    for (int k = adj_ptr[v]; k < adj_ptr[v + 1]; ++k) {
      const int f = adj_face[k];
      // F numbers slots; rest[] holds the positions in the caller's vertex order.
      const int p0 = slot_vertex[F[3 * f]], p1 = slot_vertex[F[3 * f + 1]], p2 = slot_vertex[F[3 * f + 2]];
      real a[3], b[3];
      for (int c = 0; c < 3; ++c) {
        a[c] = r_sub(rest[3 * p1 + c], rest[3 * p0 + c]);
        b[c] = r_sub(rest[3 * p2 + c], rest[3 * p0 + c]);
      }
      for (int c = 0; c < 3; ++c) {
        const int d = (c + 1) % 3, e = (c + 2) % 3;
        n[c] = r_add(n[c], r_sub(r_mul(a[d], b[e]), r_mul(a[e], b[d])));
      }
    }
    const real m = r_max(r_abs(n[0]), r_max(r_abs(n[1]), r_abs(n[2])));
    const bool zero = !r_less(r_zero(), m);
    for (int c = 0; c < 3; ++c) nrm0[3 * v + c] = zero ? 0.0 : r_to_float(r_div(n[c], m));
  }
}
