#version 450
// Volume coefficients of one axis, per tile of vertices (eqs. 13-18 as a traversal):
// each vertex's weight w_v = sum of n_f / 6 over its faces, then the tile's
// contribution sum_v w_v B_c(u_v) to its K^3 control points, and its share
// sum_v x_v w_v of the volume.
//
// Why tiles: the vertex slots are sorted by lattice cell on the device whenever the
// rest positions change (embed, radix, scan, tiles), and a tile holds up to 64 of them of
// one cell (consecutive in the sorted array), so all of them touch the same K^3
// control points. The workgroup reduces them in shared memory (each invocation owns a
// control point and sums the tile's vertices in a fixed order) and writes one partial
// row per tile; `combine` then adds the rows of each control point in tile order.
// Tiles past the real ones (NTILE is an upper bound) are empty: only their volume (0)
// is written, which solve.comp sums. The result is
// the same on every run on a device (tested), which float atomics would not give
// (and float64 atomics are rare); devices may still differ in how they fuse the
// float32 basis arithmetic.
#include "common.glsl"
layout(local_size_x = VPFFD_TILE) in;

shared real s_w[VPFFD_TILE];
shared real s_vol[VPFFD_TILE];
shared float s_bu[VPFFD_TILE * KMAX];
shared float s_bv[VPFFD_TILE * KMAX];
shared float s_bw[VPFFD_TILE * KMAX];

void main() {
  const int a = pc.axis;
  const uint l = gl_LocalInvocationID.x;
  for (uint t = gl_WorkGroupID.x; t < uint(NTILE); t += gl_NumWorkGroups.x) {
    const ivec4 tile = tiles[t];
    if (tile.y == 0) {  // the same for the whole workgroup
      if (l == 0) tile_vol[t] = r_zero();
      continue;
    }
    real w = r_zero(), vol = r_zero();
    if (int(l) < tile.y) {
      const uint v = uint(sorted[2 * (tile.x + int(l)) + 1]);  // the slot at that sorted position
      if ((pc.flags & 4) == 0) {
        for (int p = adj_ptr[v]; p < adj_ptr[v + 1]; ++p) w = r_add(w, face_normal(adj_face[p], a));
      } else {
        // A degenerate face naming v twice is listed twice in a row: each entry takes
        // the next corner at v (as the CPU's traversal does), so the two weights cancel.
        int c = -1;
        for (int p = adj_ptr[v]; p < adj_ptr[v + 1]; ++p) {
          const int f = adj_face[p];
          c = (p > adj_ptr[v] && adj_face[p - 1] == f) ? c + 1 : 0;
          while (F[3 * f + c] != int(v)) ++c;
          w = r_add(w, cone_weight(f, c, a));
        }
      }
      w = r_div(w, r_f(6.0));
      vol = r_mulf(w, X[3 * v + a]);
      float bu[KMAX], bv[KMAX], bw[KMAX];
      vertex_basis(v, bu, bv, bw);
      for (int r = 0; r < KMAX; ++r) {
        s_bu[l * KMAX + r] = bu[r];
        s_bv[l * KMAX + r] = bv[r];
        s_bw[l * KMAX + r] = bw[r];
      }
    }
    s_w[l] = w;
    s_vol[l] = vol;
    barrier();
    for (int o = int(l); o < KKK; o += VPFFD_TILE) {
      const int i = o / (KV * KW), j = (o / KW) % KV, k = o % KW;
      real s = r_zero();
      for (int q = 0; q < tile.y; ++q)
        s = r_add(s, r_mulb(s_w[q], b3(s_bu[q * KMAX + i], s_bv[q * KMAX + j], s_bw[q * KMAX + k])));
      partial[t * KKK + o] = s;
    }
    for (uint h = 32; h > 0; h >>= 1) {
      if (l < h) s_vol[l] = r_add(s_vol[l], s_vol[l + h]);
      barrier();
    }
    if (l == 0) tile_vol[t] = s_vol[0];
    barrier();
  }
}
