#version 450
// The tiles of coef.comp from the sorted (cell, slot) pairs, in three modes (pc.flags):
//   0: per sorted position, the cell ranges [start, end) (cells without vertices keep
//      the zeros the host filled in);
//   1: per cell, its number of tiles ceil(count / 64) into scan_buf (entry NKEY: 0), which
//      scan.comp turns into each cell's first tile (entry NKEY: the number of tiles);
//   2: per cell, its tiles: runs of <= 64 consecutive sorted positions.
// Tiles past the last stay empty (count 0; the host zero-fills the buffer).
// With parts a "cell" here is a sort key, part * NCP + cell (common.glsl NKEY): a part's
// tiles are then consecutive (numbered by key), and scan_buf[k * NCP] is part k's first.
#include "common.glsl"
layout(local_size_x = VPFFD_GROUP) in;

void main() {
  const uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
  const uint g = gl_GlobalInvocationID.x;
  if (pc.flags == 0) {
    for (uint p = g; p < uint(NVERT); p += stride) {
      const int c = sorted[2 * p];
      if (p == 0u || sorted[2 * (p - 1u)] != c) sorted[CELL_RANGE + 2 * c] = int(p);
      if (p + 1u == uint(NVERT) || sorted[2 * (p + 1u)] != c) sorted[CELL_RANGE + 2 * c + 1] = int(p) + 1;
    }
  } else if (pc.flags == 1) {
    for (uint c = g; c < uint(NKEY); c += stride) {
      const int n = sorted[CELL_RANGE + 2 * c + 1] - sorted[CELL_RANGE + 2 * c];
      scan_buf[c] = uint((n + VPFFD_TILE - 1) / VPFFD_TILE);
    }
    if (g == 0u) scan_buf[NKEY] = 0u;
  } else {
    for (uint c = g; c < uint(NKEY); c += stride) {
      const int start = sorted[CELL_RANGE + 2 * c], n = sorted[CELL_RANGE + 2 * c + 1] - start;
      const int t0 = int(scan_buf[c]);
      for (int j = 0; j * VPFFD_TILE < n; ++j)
        tiles[t0 + j] = ivec4(start + j * VPFFD_TILE, min(VPFFD_TILE, n - j * VPFFD_TILE), int(c), 0);
    }
  }
}
