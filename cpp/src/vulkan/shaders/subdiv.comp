#version 450
// The displaced-subdivision-surface frame (paper 002 §5.2; the CPU's
// deform_subdivision, subdiv/subdivision_frame.h), one invocation per fine vertex,
// no neighbours:
//   S' = sum_j w_j C_j,  S'_u = sum_j wu_j C_j,  S'_v = sum_j wv_j C_j   (the vertex's stencil row)
//   N_S' = unit(S'_u x S'_v),  p' = S' + d N_S',
//   N'   = unit((a_u S'_u + b_u S'_v + g_u N_S') x (a_v S'_u + b_v S'_v + g_v N_S')).
// The stencil sums are formed in reals (float64 or float-float, real.glsl) from the
// float32 control points and real weights, and rounded once to float32; the rebuild
// is float32, as multires.comp's (the error: test_subdivision_vulkan.py, subdiv_bounds).
#extension GL_GOOGLE_include_directive : require
#include "real.glsl"
#include "subdiv_layout.h"

layout(constant_id = 0) const int NVERT = 1;

layout(local_size_x = VPFFD_SD_GROUP) in;

layout(std430, set = 0, binding = VPFFD_SD_B_C) readonly buffer BufC { float C[]; };
layout(std430, set = 0, binding = VPFFD_SD_B_PTR) readonly buffer BufPtr { int ptr[]; };
layout(std430, set = 0, binding = VPFFD_SD_B_IDX) readonly buffer BufIdx { int idx[]; };
layout(std430, set = 0, binding = VPFFD_SD_B_W) readonly buffer BufW { real W[]; };
layout(std430, set = 0, binding = VPFFD_SD_B_DATA) readonly buffer BufData { float data[]; };
layout(std430, set = 0, binding = VPFFD_SD_B_X) writeonly buffer BufX { float X[]; };
layout(std430, set = 0, binding = VPFFD_SD_B_N) writeonly buffer BufN { float nrm[]; };
layout(std430, set = 0, binding = VPFFD_SD_B_S) writeonly buffer BufS { float S[]; };

float row(int r, uint v) { return data[r * NVERT + v]; }

// Zero where the vector vanishes or its length overflows, as the CPU's `len > 0` test.
vec3 unit_or_zero(vec3 c) {
  const float len = length(c);
  return (len > 0.0 && !isinf(len) && !isnan(len)) ? c / len : vec3(0.0);
}

void main() {
  const uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
  for (uint v = gl_GlobalInvocationID.x; v < uint(NVERT); v += stride) {
    // acc[3 q + a]: component a of S' (q = 0), S'_u (1), S'_v (2), in entry order as the CPU.
    real acc[9];
    for (int k = 0; k < 9; ++k) acc[k] = r_zero();
    const int e1 = ptr[v + 1];
    for (int e = ptr[v]; e < e1; ++e) {
      const int c = 3 * idx[e];
      const float q[3] = float[3](C[c], C[c + 1], C[c + 2]);
      for (int k = 0; k < 3; ++k) {
        const real w = W[3 * e + k];
        for (int a = 0; a < 3; ++a) acc[3 * k + a] = r_add(acc[3 * k + a], r_mulf(w, q[a]));
      }
    }
    const vec3 s = vec3(r_to_float(acc[0]), r_to_float(acc[1]), r_to_float(acc[2]));
    const vec3 su1 = vec3(r_to_float(acc[3]), r_to_float(acc[4]), r_to_float(acc[5]));
    const vec3 sv1 = vec3(r_to_float(acc[6]), r_to_float(acc[7]), r_to_float(acc[8]));
    const vec3 ns = unit_or_zero(cross(su1, sv1));
    const vec3 p = s + row(SD_D, v) * ns;
    const vec3 fu = row(SD_COEF, v) * su1 + row(SD_COEF + 1, v) * sv1 + row(SD_COEF + 2, v) * ns;
    const vec3 fv = row(SD_COEF + 3, v) * su1 + row(SD_COEF + 4, v) * sv1 + row(SD_COEF + 5, v) * ns;
    const vec3 n = unit_or_zero(cross(fu, fv));
    for (int a = 0; a < 3; ++a) {
      X[3 * v + a] = p[a];
      nrm[3 * v + a] = n[a];
      S[3 * v + a] = s[a];
    }
  }
}
