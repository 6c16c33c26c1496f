#version 450
// alpha[c] = sum of the tile partials that touch control point c, in tile order: the
// tiles of the (at most K^3) cells whose K^3 block holds c, cells in increasing index
// (tiles are numbered by cell, tiles.comp), each cell's tiles in order. The order
// depends only on the cell table, so reruns are bit-identical.
#include "common.glsl"
layout(local_size_x = VPFFD_GROUP) in;

void main() {
  const uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
  for (uint c = gl_GlobalInvocationID.x; c < uint(NCP); c += stride) {
    const int i = int(c) / (NV * NW), j = (int(c) / NW) % NV, k = int(c) % NW;
    real s = r_zero();
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
          for (uint t = scan_buf[cell]; t < scan_buf[cell + 1]; ++t) s = r_add(s, partial[int(t) * KKK + o]);
        }
      }
    }
    alpha[c] = s;
  }
}
