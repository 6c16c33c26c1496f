#version 450
// The multiresolution frame (paper 002, eq. 1 and eqs. 6-7; the CPU's MultiresFFD),
// one invocation per fine vertex, no neighbours:
//   S' = D(S(t_i)), S'_u = J_D S_u, S'_v = J_D S_v   (J_D: the FFD's Jacobian at the foot point)
//   N_S' = unit(S'_u x S'_v),  p' = S' + d N_S',
//   N'   = unit((a_u S'_u + b_u S'_v + g_u N_S') x (a_v S'_u + b_v S'_v + g_v N_S')).
// The foot points are fixed rest-space points: their spans and local parameters come
// from the host once, with S_u, S_v, d and the coefficients; a frame reads the control
// points alone. The basis values and derivatives are evaluated in reals and rounded
// once (basis_reals.glsl), the tensor sums and the rest are float32 (their error:
// tests/python/gpu_bounds.py, multires_bounds).
#extension GL_GOOGLE_include_directive : require
#include "real.glsl"
#include "multires_layout.h"

#define KMAX 6  // order (degree + 1) of a degree-5 spline

// Fixed per VulkanMultires: they let the compiler unroll the basis loops.
layout(constant_id = 0) const int KU = 4;
layout(constant_id = 1) const int KV = 4;
layout(constant_id = 2) const int KW = 4;
layout(constant_id = 3) const int NU = 4;
layout(constant_id = 4) const int NV = 4;
layout(constant_id = 5) const int NW = 4;
layout(constant_id = 6) const int NVERT = 1;
layout(constant_id = 7) const int POLY_V = 0;  // start of axis v's span table in `tab`
layout(constant_id = 8) const int POLY_W = 0;
// A periodic lattice: the distinct control points (0: none; corrected.comp's tie map)
// and whether the frame data has the shift seam's rows (MR_SHIFT).
layout(constant_id = 9) const int NDIST = 0;
layout(constant_id = 10) const int SHIFTED = 0;

layout(local_size_x = VPFFD_MR_GROUP) in;

layout(std430, set = 0, binding = VPFFD_MR_B_P) readonly buffer BufP { float P[]; };
layout(std430, set = 0, binding = VPFFD_MR_B_TAB) readonly buffer BufTab { real tab[]; };
layout(std430, set = 0, binding = VPFFD_MR_B_SPAN) readonly buffer BufSpan { int span[]; };
layout(std430, set = 0, binding = VPFFD_MR_B_DATA) readonly buffer BufData { float data[]; };
layout(std430, set = 0, binding = VPFFD_MR_B_X) writeonly buffer BufX { float X[]; };
layout(std430, set = 0, binding = VPFFD_MR_B_N) writeonly buffer BufN { float nrm[]; };

#define BASIS_TAB tab
#include "basis_reals.glsl"

float row(int r, uint v) { return data[r * NVERT + v]; }
vec3 rows3(int r, uint v) { return vec3(row(r, v), row(r + 1, v), row(r + 2, v)); }

// Zero where the vector vanishes or its length overflows, as the CPU's `len > 0` test.
vec3 unit_or_zero(vec3 c) {
  const float len = length(c);
  return (len > 0.0 && !isinf(len) && !isnan(len)) ? c / len : vec3(0.0);
}

void main() {
  // Start of the derivative scales in `tab`: after the three axes' span tables.
  const int ds_u = POLY_W + KW * KW * (NW - KW + 1);
  const int ds_v = ds_u + (NU - KU + 1);
  const int ds_w = ds_v + (NV - KV + 1);
  const uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
  for (uint v = gl_GlobalInvocationID.x; v < uint(NVERT); v += stride) {
    const int i0 = span[v], j0 = span[NVERT + v], k0 = span[2 * NVERT + v];
    float bu[KMAX], bv[KMAX], bw[KMAX], du[KMAX], dv[KMAX], dw[KMAX];
    eval_axis_d(0, KU, i0, row(MR_TAU, v), tab[ds_u + i0], bu, du);
    eval_axis_d(POLY_V, KV, j0, row(MR_TAU + 1, v), tab[ds_v + j0], bv, dv);
    eval_axis_d(POLY_W, KW, k0, row(MR_TAU + 2, v), tab[ds_w + k0], bw, dw);
    const int base = (i0 * NV + j0) * NW + k0;
    // D and the columns of J (c_a = sum_c q_c dB_c/dy_a) in one tensor pass,
    // innermost axis first as ffd.comp and normals.comp.
    vec3 s = vec3(0.0), c0 = vec3(0.0), c1 = vec3(0.0), c2 = vec3(0.0);
    for (int i = 0; i < KU; ++i) {
      vec3 a00 = vec3(0.0), a10 = vec3(0.0), a01 = vec3(0.0);  // (v, w) = (B, B), (B', B), (B, B')
      for (int j = 0; j < KV; ++j) {
        const int r = base + (i * NV + j) * NW;
        vec3 s0 = vec3(0.0), s1 = vec3(0.0);
        for (int k = 0; k < KW; ++k) {
          const int c = 3 * (r + k);
          const vec3 q = vec3(P[c], P[c + 1], P[c + 2]);
          s0 += bw[k] * q;
          s1 += dw[k] * q;
        }
        a00 += bv[j] * s0;
        a10 += dv[j] * s0;
        a01 += bv[j] * s1;
      }
      s += bu[i] * a00;
      c0 += du[i] * a00;
      c1 += bu[i] * a10;
      c2 += bu[i] * a01;
    }
    // The image of the foot point as given: a shift seam's translation (float32, added
    // once), zero rows for the points no seam moved.
    if (SHIFTED != 0) s += rows3(MR_SHIFT, v);
    const vec3 su = rows3(MR_SU, v), sv = rows3(MR_SV, v);
    const vec3 su1 = su.x * c0 + su.y * c1 + su.z * c2;
    const vec3 sv1 = sv.x * c0 + sv.y * c1 + sv.z * c2;
    const vec3 ns = unit_or_zero(cross(su1, sv1));
    const vec3 p = s + row(MR_D, v) * ns;
    const vec3 fu = row(MR_COEF, v) * su1 + row(MR_COEF + 1, v) * sv1 + row(MR_COEF + 2, v) * ns;
    const vec3 fv = row(MR_COEF + 3, v) * su1 + row(MR_COEF + 4, v) * sv1 + row(MR_COEF + 5, v) * ns;
    const vec3 n = unit_or_zero(cross(fu, fv));
    X[3 * v] = p.x;
    X[3 * v + 1] = p.y;
    X[3 * v + 2] = p.z;
    nrm[3 * v] = n.x;
    nrm[3 * v + 1] = n.y;
    nrm[3 * v + 2] = n.z;
  }
}
