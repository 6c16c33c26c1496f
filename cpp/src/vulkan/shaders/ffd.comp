#version 450
// Plain FFD of every vertex (eq. 1): X = sum_ijk B_i(u) B_j(v) B_k(w) P_ijk, over the
// extended control points of a periodic lattice (the host expands them), plus the
// translation a "shift" seam adds to a vertex wrapped into the box (embed.comp).
#include "common.glsl"
layout(local_size_x = VPFFD_GROUP) in;

void main() {
  const uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
  for (uint v = gl_GlobalInvocationID.x; v < uint(NVERT); v += stride) {
    float bu[KMAX], bv[KMAX], bw[KMAX];
    const int base = vertex_basis(v, bu, bv, bw);
    vec3 acc = vec3(0.0);
    for (int i = 0; i < KU; ++i) {
      vec3 ai = vec3(0.0);
      for (int j = 0; j < KV; ++j) {
        const int row = base + (i * NV + j) * NW;
        vec3 aj = vec3(0.0);
        for (int k = 0; k < KW; ++k) {
          const int c = 3 * (row + k);
          aj += bw[k] * vec3(P[c], P[c + 1], P[c + 2]);
        }
        ai += bv[j] * aj;
      }
      acc += bu[i] * ai;
    }
    if (ANY_SHIFT) acc += seam[v].xyz;
    X[3 * v] = acc.x;
    X[3 * v + 1] = acc.y;
    X[3 * v + 2] = acc.z;
  }
}
