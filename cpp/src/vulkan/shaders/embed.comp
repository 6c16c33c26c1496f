#version 450
// The embedding of every vertex slot (the first phase of 001's two-phase evaluation):
// from its rest position, per axis the knot span and the local parameter that the
// other passes read, and the slot's cell, the key of the cell sort (radix.comp).
// The rules are the CPU's (lattice/embed.h, bspline/knots.h find_span): the affine
// parameter map, clamped into the domain unless outside = extrapolate; the last span
// s in [d, n - 1] with t_s <= u, past either end the first or last non-empty one.
// The parameter is computed in reals (float64 or float-float, from rest positions in
// reals) and rounded once to float32, so tau errs by half a float32 ulp as when the
// host embedded; where u lies within a real's rounding of a knot the span may be the
// neighbour of the CPU's, which gives the same point (the spline is continuous there).
// Also writes X = the rest positions: the device vertices before any frame.
#include "common.glsl"
layout(local_size_x = VPFFD_GROUP) in;

const int TAB = 3 * NVERT;  // the embedding table after the positions

int knots_at(int a) { return TAB + EM_KNOTS + (a > 0 ? NU + KU : 0) + (a > 1 ? NV + KV : 0); }

// Last s in [d, n - 1] with t[s] <= u (find_span of bspline/knots.h).
int find_span(int off, int n, int d, real u) {
  if (!r_less(u, rest[off + n])) {
    int s = n - 1;
    while (rest[off + s] == rest[off + s + 1]) --s;
    return s;
  }
  if (r_less(u, rest[off + d])) {
    int s = d;
    while (rest[off + s] == rest[off + s + 1]) ++s;
    return s;
  }
  int lo = d, hi = n;  // t[lo] <= u < t[hi]
  while (hi - lo > 1) {
    const int mid = (lo + hi) / 2;
    if (r_less(u, rest[off + mid])) hi = mid;
    else lo = mid;
  }
  return lo;
}

void main() {
  const uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
  const bool clamp_u = (pc.flags & EM_CLAMP) != 0;
  for (uint v = gl_GlobalInvocationID.x; v < uint(NVERT); v += stride) {
    int first[3];
    for (int a = 0; a < 3; ++a) {
      const int n = a == 0 ? NU : (a == 1 ? NV : NW);
      const int d = (a == 0 ? KU : (a == 1 ? KV : KW)) - 1;
      const int off = knots_at(a);
      const real y = rest[3 * v + a];
      real u = r_add(rest[TAB + EM_U0 + a], r_mul(y, rest[TAB + EM_DU + a]));
      if (clamp_u) {
        if (r_less(u, rest[off + d])) u = rest[off + d];
        if (r_less(rest[off + n], u)) u = rest[off + n];
      }
      const int s = find_span(off, n, d, u);
      const real t0 = rest[off + s];
      tau[3 * v + a] = r_to_float(r_div(r_sub(u, t0), r_sub(rest[off + s + 1], t0)));
      first[a] = s - d;
      span[3 * v + a] = s - d;
      X[3 * v + a] = r_to_float(y);
    }
    sorted[2 * v] = (first[0] * NV + first[1]) * NW + first[2];
    sorted[2 * v + 1] = int(v);
  }
}
