#version 450
// alpha[c] = sum of the tile partials that touch control point c, in tile order.
#include "common.glsl"
layout(local_size_x = VPFFD_GROUP) in;

void main() {
  const uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
  for (uint c = gl_GlobalInvocationID.x; c < uint(NCP); c += stride) {
    real s = r_zero();
    for (int p = comb_ptr[c]; p < comb_ptr[c + 1]; ++p) s = r_add(s, partial[comb_idx[p]]);
    alpha[c] = s;
  }
}
