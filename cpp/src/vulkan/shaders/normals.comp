#version 450
// Exact deformed vertex normals (ffd/normals.h, deformed_normals_exact):
// N = normalize(cof(J) n0), with J = dD/dx the FFD's Jacobian at the rest vertex and
// n0 its rest normal. A tangent t maps to J t, so the tangent plane with normal
// t1 x t2 maps to one with normal (J t1) x (J t2) = cof(J) (t1 x t2): no inverse, and
// defined where J is singular (a zero vector there, as on the CPU).
//
// The control points are those of the finished frame: P plus, when pc.flags bit 8 is
// set, the three accumulated offset rows of `delta` (a corrected frame). Runs last in
// the frame's command buffer, after the final vertex update, so it costs no second
// submission. The derivative of a span's power form, sum_q q c_q tau^(q-1), is
// evaluated by the same Horner pass as the values, as the CPU's eval_span_derivs does,
// then scaled by d tau / d y (`nrm_tab` after its copy of the basis table: per axis and
// span, dtau/du * du/dy in device units). Only directions matter, but the axes' scales
// must be right relative to each other.
//
// Why the basis is evaluated in reals here (the FFD's is float32): see basis_reals.glsl;
// with it the angle bound proves the issue's 0.01 degree (tests/python/gpu_bounds.py,
// normal_angle_bound). On a periodic lattice P is extended and the offsets are the
// distinct points' (tie()), as in ffd.comp and gather.comp. 3 K^2 real operations per vertex, against the K^3 float32 ones
// of the Jacobian.
#include "common.glsl"
layout(local_size_x = VPFFD_GROUP) in;

#define BASIS_TAB nrm_tab
#include "basis_reals.glsl"

void main() {
  const bool offsets = (pc.flags & 8) != 0;
  // Start of the derivative scales in `nrm_tab`: after the three axes' span tables
  // (n - d spans of K x K coefficients each).
  const int ds_u = POLY_W + KW * KW * (NW - KW + 1);
  const int ds_v = ds_u + (NU - KU + 1);
  const int ds_w = ds_v + (NV - KV + 1);
  const uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
  for (uint v = gl_GlobalInvocationID.x; v < uint(NVERT); v += stride) {
    const int i0 = span[3 * v], j0 = span[3 * v + 1], k0 = span[3 * v + 2];
    float bu[KMAX], bv[KMAX], bw[KMAX], du[KMAX], dv[KMAX], dw[KMAX];
    eval_axis_d(0, KU, i0, tau[3 * v], nrm_tab[ds_u + i0], bu, du);
    eval_axis_d(POLY_V, KV, j0, tau[3 * v + 1], nrm_tab[ds_v + j0], bv, dv);
    eval_axis_d(POLY_W, KW, k0, tau[3 * v + 2], nrm_tab[ds_w + k0], bw, dw);
    const int base = (i0 * NV + j0) * NW + k0;
    // Tensor-product sums, innermost axis first (as ffd.comp): column a of J is
    // sum_c q_c dB_c/dy_a.
    vec3 c0 = vec3(0.0), c1 = vec3(0.0), c2 = vec3(0.0);
    for (int i = 0; i < KU; ++i) {
      vec3 a00 = vec3(0.0), a10 = vec3(0.0), a01 = vec3(0.0);  // (v, w) = (B, B), (B', B), (B, B')
      for (int j = 0; j < KV; ++j) {
        const int row = base + (i * NV + j) * NW;
        vec3 s0 = vec3(0.0), s1 = vec3(0.0);
        for (int k = 0; k < KW; ++k) {
          const int c = row + k;
          vec3 q = vec3(P[3 * c], P[3 * c + 1], P[3 * c + 2]);
          if (offsets) {
            const int e = tie(c);
            q += vec3(r_to_float(delta[e]), r_to_float(delta[NDC + e]), r_to_float(delta[2 * NDC + e]));
          }
          s0 += bw[k] * q;
          s1 += dw[k] * q;
        }
        a00 += bv[j] * s0;
        a10 += dv[j] * s0;
        a01 += bv[j] * s1;
      }
      c0 += du[i] * a00;
      c1 += bu[i] * a10;
      c2 += bu[i] * a01;
    }
    vec3 n0 = vec3(nrm0[3 * v], nrm0[3 * v + 1], nrm0[3 * v + 2]);
    // A vertex that a twist seam mirrored (embed.comp): the map of the point as given
    // is D(M x), M the mirror of the two other axes (det M = 1, M^-T = M), whose
    // cofactor matrix is cof(J) M: the rest normal is mirrored (the CPU negates J's
    // columns instead, lattice/periodic.h unmirror_jacobian; the same products).
    if (ANY_TWIST && seam[v].w != 0.0)
      for (int a = 0; a < 3; ++a)
        if (seam_of(a) != SEAM_TWIST) n0[a] = -n0[a];
    const vec3 n = n0.x * cross(c1, c2) + n0.y * cross(c2, c0) + n0.z * cross(c0, c1);
    const float len = length(n);
    // Zero where cof(J) n0 vanishes or overflows, as the CPU's normalized_or_zero.
    const vec3 out_n = (len > 0.0 && !isinf(len) && !isnan(len)) ? n / len : vec3(0.0);
    nrm[3 * v] = out_n.x;
    nrm[3 * v + 1] = out_n.y;
    nrm[3 * v + 2] = out_n.z;
  }
}
