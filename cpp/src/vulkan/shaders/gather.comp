#version 450
// X[v][axis] += sum_c B_c(u_v) delta_c, with delta the row pc.slot of `delta` (this
// step's offsets, or an axis's total when the host solved the frame): after a
// correction along one axis only that coordinate moves. The basis products are
// formed exactly as in `coef` (b3), so the volume change is alpha . delta up to
// the float32 rounding of X. On a periodic lattice delta holds the distinct control
// points' offsets and an extended point takes its distinct one's (tie(): a copy).
#include "common.glsl"
layout(local_size_x = VPFFD_GROUP) in;

void main() {
  const int a = pc.axis;
  const int src = pc.slot * NDC;
  const uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
  for (uint v = gl_GlobalInvocationID.x; v < uint(NVERT); v += stride) {
    float bu[KMAX], bv[KMAX], bw[KMAX];
    const int base = vertex_basis(v, bu, bv, bw);
    real s = r_zero();
    for (int i = 0; i < KU; ++i) {
      for (int j = 0; j < KV; ++j) {
        const int row = base + (i * NV + j) * NW;
        for (int k = 0; k < KW; ++k) s = r_add(s, r_mulb(delta[src + tie(row + k)], b3(bu[i], bv[j], bw[k])));
      }
    }
    X[3 * v + a] = r_to_float(r_add(r_f(X[3 * v + a]), s));
  }
}
