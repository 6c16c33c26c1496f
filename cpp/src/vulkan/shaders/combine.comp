#version 450
// alpha[c] = sum of the tile partials that touch control point c, in tile order: the
// tiles of the (at most K^3) cells whose K^3 block holds c, cells in increasing index
// (tiles are numbered by cell, tiles.comp), each cell's tiles in order. The order
// depends only on the cell table, so reruns are bit-identical. On a periodic lattice
// alpha is over the distinct control points: each sums the tiles of all its extended
// copies (the fold, lattice/periodic.h), still in a fixed order. With parts (NPART > 1)
// there is one row per part, alpha[k * NDC + c]: the same sum over part k's tiles only
// (those of the keys k * NCP + cell, tiles.comp), so each part's row is its own mesh's.
#include "common.glsl"
layout(local_size_x = VPFFD_GROUP) in;

// The tiles' partials of extended control point c, added to s.
real add_tiles(int c, int key0, real s) {
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
        for (uint t = scan_buf[key0 + cell]; t < scan_buf[key0 + cell + 1]; ++t) s = r_add(s, partial[int(t) * KKK + o]);
      }
    }
  }
  return s;
}

void main() {
  const uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
  for (uint row = gl_GlobalInvocationID.x; row < uint(NPART * NDC); row += stride) {
    const int k = int(row) / NDC, c = int(row) % NDC, key0 = k * NCP;
    real s = r_zero();
    if (TIED) {
      // The fold of lattice/periodic.h: a distinct point's coefficient is the sum of
      // those of its extended copies (itself first), in increasing index.
      for (int p = ties[TIE_PTR + c]; p < ties[TIE_PTR + c + 1]; ++p) s = add_tiles(ties[TIE_LIST + p], key0, s);
    } else {
      s = add_tiles(c, key0, s);
    }
    alpha[row] = s;
  }
}
