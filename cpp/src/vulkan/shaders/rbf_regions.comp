#version 450
// The RBF regions frame (paper 002 §6; the CPU's RbfRegions::deform,
// multires/rbf_regions.h), one invocation per fine vertex, no neighbours:
//   fixed vertex:  its rest fine vertex, normal and base vertex;
//   handle vertex (region k): p' = T_k p, q' = T_k q, n' = unit(cof(A_k) n);
//   free vertex:   S' = S + sum_k D_k alpha_k(S), S'_u, S'_v and the base vertex
//                  likewise from the precomputed basis, then
//                  N_S' = unit(S'_u x S'_v), p' = S' + d N_S',
//                  N' = unit((a_u S'_u + b_u S'_v + g_u N_S') x (a_v S'_u + b_v S'_v + g_v N_S')).
// The affine sums are formed in reals (float64 or float-float, real.glsl) from real
// rest points, basis and maps and rounded once to float32; the rebuild is float32, as
// subdiv.comp's (the error: test_rbf_regions_vulkan.py, rbf_bounds).
#extension GL_GOOGLE_include_directive : require
#include "real.glsl"
#include "rbf_regions_layout.h"

layout(constant_id = 0) const int NVERT = 1;
layout(constant_id = 1) const int NREG = 1;

layout(local_size_x = VPFFD_RB_GROUP) in;

layout(std430, set = 0, binding = VPFFD_RB_B_MAPS) readonly buffer BufMaps { real maps[]; };
layout(std430, set = 0, binding = VPFFD_RB_B_LAB) readonly buffer BufLab { int lab[]; };
layout(std430, set = 0, binding = VPFFD_RB_B_PTS) readonly buffer BufPts { real pts[]; };
layout(std430, set = 0, binding = VPFFD_RB_B_BASIS) readonly buffer BufBasis { real basis[]; };
layout(std430, set = 0, binding = VPFFD_RB_B_DATA) readonly buffer BufData { float data[]; };
layout(std430, set = 0, binding = VPFFD_RB_B_X) writeonly buffer BufX { float X[]; };
layout(std430, set = 0, binding = VPFFD_RB_B_N) writeonly buffer BufN { float nrm[]; };
layout(std430, set = 0, binding = VPFFD_RB_B_B) writeonly buffer BufB { float B[]; };

float row(int r, uint v) { return data[r * NVERT + v]; }
real pt(int r, uint v) { return pts[r * NVERT + v]; }

// Zero where the vector vanishes or its length overflows, as the CPU's `len > 0` test.
vec3 unit_or_zero(vec3 c) {
  const float len = length(c);
  return (len > 0.0 && !isinf(len) && !isnan(len)) ? c / len : vec3(0.0);
}

// T p for the 3 x 4 map at maps[o] and the point in rows r..r+2, rounded once to float32.
vec3 affine(int o, int r, uint v) {
  vec3 out_;
  for (int a = 0; a < 3; ++a) {
    real acc = maps[o + 4 * a + 3];
    for (int c = 0; c < 3; ++c) acc = r_add(acc, r_mul(maps[o + 4 * a + c], pt(r + c, v)));
    out_[a] = r_to_float(acc);
  }
  return out_;
}

void main() {
  const uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
  for (uint v = gl_GlobalInvocationID.x; v < uint(NVERT); v += stride) {
    const int l = lab[2 * v];
    vec3 p, n, q;
    const vec3 n0 = vec3(row(RB_NRM, v), row(RB_NRM + 1, v), row(RB_NRM + 2, v));
    if (l < 0) {  // fixed: the rest data
      for (int a = 0; a < 3; ++a) {
        p[a] = r_to_float(pt(RB_S + a, v));
        q[a] = r_to_float(pt(RB_Q + a, v));
      }
      n = n0;
    } else if (l > 0) {  // handle region l: its affine map; the normal by its cofactor
      const int o = (l - 1) * RB_MAP_REALS;
      p = affine(o + RB_MAP_T, RB_S, v);
      q = affine(o + RB_MAP_T, RB_Q, v);
      // cof n in reals, rounded once: the normal of the affinely mapped surface.
      vec3 c;
      for (int a = 0; a < 3; ++a) {
        real acc = r_zero();
        for (int b = 0; b < 3; ++b) acc = r_add(acc, r_mulf(maps[o + RB_MAP_COF + 3 * a + b], n0[b]));
        c[a] = r_to_float(acc);
      }
      n = unit_or_zero(c);
    } else {  // free: the RBF map of the foot point, tangents and base vertex
      const int f = lab[2 * v + 1];
      const int b0 = f * 16 * NREG;
      // acc[3 t + a]: component a of S' (t = 0), S'_u (1), S'_v (2), the base vertex (3).
      real acc[12];
      for (int k = 0; k < 12; ++k) acc[k] = pt(k, v);
      for (int k = 0; k < NREG; ++k) {
        const int o = k * RB_MAP_REALS + RB_MAP_D;
        for (int t = 0; t < 4; ++t) {
          const int bb = b0 + 4 * (t * NREG + k);
          for (int a = 0; a < 3; ++a) {
            real s = r_zero();
            for (int c = 0; c < 4; ++c) s = r_add(s, r_mul(maps[o + 4 * a + c], basis[bb + c]));
            acc[3 * t + a] = r_add(acc[3 * t + a], s);
          }
        }
      }
      const vec3 s = vec3(r_to_float(acc[0]), r_to_float(acc[1]), r_to_float(acc[2]));
      const vec3 su1 = vec3(r_to_float(acc[3]), r_to_float(acc[4]), r_to_float(acc[5]));
      const vec3 sv1 = vec3(r_to_float(acc[6]), r_to_float(acc[7]), r_to_float(acc[8]));
      q = vec3(r_to_float(acc[9]), r_to_float(acc[10]), r_to_float(acc[11]));
      const vec3 ns = unit_or_zero(cross(su1, sv1));
      p = s + row(RB_D, v) * ns;
      const vec3 fu = row(RB_COEF, v) * su1 + row(RB_COEF + 1, v) * sv1 + row(RB_COEF + 2, v) * ns;
      const vec3 fv = row(RB_COEF + 3, v) * su1 + row(RB_COEF + 4, v) * sv1 + row(RB_COEF + 5, v) * ns;
      n = unit_or_zero(cross(fu, fv));
    }
    for (int a = 0; a < 3; ++a) {
      X[3 * v + a] = p[a];
      nrm[3 * v + a] = n[a];
      B[3 * v + a] = q[a];
    }
  }
}
