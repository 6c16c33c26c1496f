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
// With EM_OFFSET (set_rest_offsets) a slot's position is its base position in rest[]
// plus its part's translation, stored after the knots: only K translations travel per
// move, and the sum is rounded once in reals (the host's base + offset in float64
// differs from it by a real's rounding).
// On periodic axes the position is first wrapped into the box (wrap below); the
// spans and parameters are those of the wrapped position, `seam` keeps what the
// wrap did (ffd.comp adds the translation, normals.comp applies the mirror).
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

// wrap_point of lattice/embed.h in device units (the box's faces, extent and mirror
// from the table): per periodic axis the position moved into [lo, hi) by whole extents,
// with the translation a "shift" seam adds to its image and the parity of the turns of
// a "twist" seam, which mirrors the two other coordinates in the box. The same rules as
// the CPU's in reals, so a position within a real's rounding of a face may land on the
// other face; both give the same image (the spline is periodic there, the translation
// and the mirror follow the side taken).
void wrap(inout real y[3], out vec4 moved) {
  bool flip = false;
  moved = vec4(0.0);
  for (int a = 0; a < 3; ++a) {
    const int sm = seam_of(a);
    if (sm == SEAM_NONE) continue;
    const real lo = rest[TAB + EM_LO + a], ext = rest[TAB + EM_EXT + a];
    real turns = r_floor(r_div(r_sub(y[a], lo), ext));
    real w = r_sub(y[a], r_mul(turns, ext));
    if (!r_less(w, rest[TAB + EM_HI + a])) {
      w = r_sub(w, ext);
      turns = r_add(turns, r_f(1.0));
    }
    if (r_less(w, lo)) w = lo;
    // The translation the position was moved by, as the CPU's x - y.
    if (sm == SEAM_SHIFT) moved[a] = r_to_float(r_sub(y[a], w));
    if (sm == SEAM_TWIST) flip = r_hi(r_sub(turns, r_mulf(r_floor(r_mulf(turns, 0.5)), 2.0))) != 0.0;
    y[a] = w;
  }
  if (flip) {
    // A twist axis's two other axes are not periodic (validate_periodic).
    for (int b = 0; b < 3; ++b)
      if (seam_of(b) != SEAM_TWIST) y[b] = r_sub(rest[TAB + EM_MID + b], y[b]);
    moved.w = 1.0;
  }
}

void main() {
  const uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
  const bool clamp_u = (pc.flags & EM_CLAMP) != 0;
  const bool offset = (pc.flags & EM_OFFSET) != 0;
  const int offsets_at = knots_at(2) + NW + KW;  // after the three knot vectors
  for (uint v = gl_GlobalInvocationID.x; v < uint(NVERT); v += stride) {
    real y[3];
    const int p = 3 * slot_vertex[v];
    const int part = NPART > 1 ? parts[PT_SLOT + v] : 0;
    for (int a = 0; a < 3; ++a) {
      y[a] = rest[p + a];
      if (offset) y[a] = r_add(y[a], rest[offsets_at + 3 * part + a]);
      X[3 * v + a] = r_to_float(y[a]);
    }
    if (SEAMS != 0) {
      vec4 moved;
      wrap(y, moved);
      if (ANY_SHIFT || ANY_TWIST) seam[v] = moved;
    }
    int first[3];
    for (int a = 0; a < 3; ++a) {
      const int n = a == 0 ? NU : (a == 1 ? NV : NW);
      const int d = (a == 0 ? KU : (a == 1 ? KV : KW)) - 1;
      const int off = knots_at(a);
      real u = r_add(rest[TAB + EM_U0 + a], r_mul(y[a], rest[TAB + EM_DU + a]));
      if (clamp_u) {
        if (r_less(u, rest[off + d])) u = rest[off + d];
        if (r_less(rest[off + n], u)) u = rest[off + n];
      }
      const int s = find_span(off, n, d, u);
      const real t0 = rest[off + s];
      tau[3 * v + a] = r_to_float(r_div(r_sub(u, t0), r_sub(rest[off + s + 1], t0)));
      first[a] = s - d;
      span[3 * v + a] = s - d;
    }
    // The sort key: the cell, after the part (the most significant digits: each part's
    // slots become one range of sorted positions, as the CPU's part_start).
    sorted[2 * v] = part * NCP + (first[0] * NV + first[1]) * NW + first[2];
    sorted[2 * v + 1] = int(v);
  }
}
