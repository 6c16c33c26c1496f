#version 450
// Offsets of one axis step: delta = W^-1 R^T lambda, with R the volume row alpha
// and the constraint rows; also the per-workgroup max |delta|.
#include "common.glsl"
layout(local_size_x = 256) in;
shared double s_max[256];

void main() {
  const uint l = gl_LocalInvocationID.x;
  const bool volrow = (pc.flags & 1) != 0;
  const int nc = par_i[PI_NC];
  const int nv = volrow ? 1 : 0;
  const int lam = ST_LAMBDA + pc.step * ST_LAMBDA_STRIDE;
  const uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
  double mx = 0.0;
  for (uint c = gl_GlobalInvocationID.x; c < uint(NCP); c += stride) {
    double d = 0.0;
    const double iw = inv_w[c];
    if (iw > 0.0) {
      double s = volrow ? stats[lam] * alpha[c] : 0.0;
      for (int q = 0; q < nc; ++q) s += stats[lam + nv + q] * constraint_row(q, int(c));
      d = iw * s;
    }
    delta[pc.axis * NCP + c] = d;
    mx = max(mx, abs(d));
  }
  s_max[l] = mx;
  barrier();
  for (uint h = 128; h > 0; h >>= 1) {
    if (l < h) s_max[l] = max(s_max[l], s_max[l + h]);
    barrier();
  }
  if (l == 0) red[gl_WorkGroupID.x] = s_max[0];
}
