#version 450
// alpha[c] = sum of the tile partials that touch control point c: the tiles of the (at
// most K^3) cells whose K^3 block holds c, cells in increasing index (tiles are
// numbered by cell, tiles.comp). On a periodic lattice alpha is over the distinct
// control points: each sums the tiles of all its extended copies (the fold,
// lattice/periodic.h). With parts (NPART > 1) there is one row per part,
// alpha[k * NDC + c]: the same sum over part k's tiles only (those of the keys
// k * NCP + cell, tiles.comp), so each part's row is its own mesh's.
//
// LANES invocations per row (specialisation constant 15, set by the host): a control
// point of a large mesh sums thousands of tiles (a 2.6 M-vertex icosphere in a 10^3
// lattice: ~7,700), which one invocation per row did in sequence on a handful of
// workgroups (6-7 ms an axis on an H100). On a GPU, lane l of a row takes tiles l,
// l + LANES, ... of each cell in turn and the row's lanes are added in a fixed tree,
// so the order (and every bit of the result) still depends only on the cell table
// and the tile counts: reruns are bit-identical. A CPU device (lavapipe) runs a
// workgroup's invocations one after another, so the lanes gain nothing there and the
// barriers cost (an axis on icosphere(6): 250 ms with one lane, 315 with 64): LANES
// is 1 there, one invocation per row, the sequential sum.
#include "common.glsl"
layout(local_size_x = VPFFD_TILE) in;
layout(constant_id = 15) const int LANES = 1;  // invocations per row: a power of two <= VPFFD_TILE

shared real s_sum[VPFFD_TILE];

// Lane `lane`'s share of the tile partials of extended control point c, added to s.
real add_tiles(int c, int key0, uint lane, real s) {
  const int i = c / (NV * NW), j = (c / NW) % NV, k = c % NW;
  // Cell (i - di, j - dj, k - dk) holds c at local (di, dj, dk); decreasing offsets
  // visit the cells in increasing index.
  for (int di = KU - 1; di >= 0; --di) {
    const int ci = i - di;
    if (ci < 0 || ci > NU - KU) continue;
    for (int dj = KV - 1; dj >= 0; --dj) {
      const int cj = j - dj;
      if (cj < 0 || cj > NV - KV) continue;
      for (int dk = KW - 1; dk >= 0; --dk) {
        const int ck = k - dk;
        if (ck < 0 || ck > NW - KW) continue;
        const int cell = (ci * NV + cj) * NW + ck, o = (di * KV + dj) * KW + dk;
        const uint end = scan_buf[key0 + cell + 1];
        for (uint t = scan_buf[key0 + cell] + lane; t < end; t += uint(LANES)) s = r_add(s, partial[int(t) * KKK + o]);
      }
    }
  }
  return s;
}

void main() {
  const uint l = gl_LocalInvocationID.x, lane = l % uint(LANES), per_group = uint(VPFFD_TILE / LANES);
  const uint rows = uint(NPART * NDC);
  // `base` is the same for the whole workgroup, so every invocation meets the barriers.
  for (uint base = gl_WorkGroupID.x * per_group; base < rows; base += gl_NumWorkGroups.x * per_group) {
    const uint row = base + l / uint(LANES);
    real s = r_zero();
    if (row < rows) {
      const int k = int(row) / NDC, c = int(row) % NDC, key0 = k * NCP;
      if (TIED) {
        // The fold of lattice/periodic.h: a distinct point's coefficient is the sum of
        // those of its extended copies (itself first), in increasing index.
        for (int p = ties[TIE_PTR + c]; p < ties[TIE_PTR + c + 1]; ++p) s = add_tiles(ties[TIE_LIST + p], key0, lane, s);
      } else {
        s = add_tiles(c, key0, lane, s);
      }
    }
    if (LANES == 1) {
      if (row < rows) alpha[row] = s;
    } else {
      s_sum[l] = s;
      barrier();
      for (uint h = uint(LANES) / 2; h > 0; h >>= 1) {
        if (lane < h) s_sum[l] = r_add(s_sum[l], s_sum[l + h]);
        barrier();
      }
      if (lane == 0 && row < rows) alpha[row] = s_sum[l];
      barrier();  // s_sum is rewritten for the next rows
    }
  }
}
