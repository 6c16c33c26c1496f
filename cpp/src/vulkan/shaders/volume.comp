#version 450
// Enclosed volume, per workgroup: sum_f p0 . (p1 x p2) with positions relative to
// the lattice centre (the CPU's signed_volume), in reals, into region pc.slot of
// `red`. The host adds the (at most RED_STRIDE) partials in a fixed order: a
// one-workgroup reduce pass would cost a dispatch and a barrier for 1024 additions.
// With parts (NPART > 1; the faces are grouped by part, parts[PT_FACE_START..]) the
// workgroups are split in NPART runs of pc.count: workgroup k * pc.count + j sums part k's
// faces j, j + pc.count, ... (in groups of 256), so the host adds part k's partials alone.
#include "common.glsl"
layout(local_size_x = VPFFD_GROUP) in;
shared real s_sum[VPFFD_GROUP];

real face_volume(uint f) {
  const int v0 = F[3 * f], v1 = F[3 * f + 1], v2 = F[3 * f + 2];
  const vec3 a = vec3(X[3 * v0], X[3 * v0 + 1], X[3 * v0 + 2]);
  const vec3 b = vec3(X[3 * v1], X[3 * v1 + 1], X[3 * v1 + 2]);
  const vec3 c = vec3(X[3 * v2], X[3 * v2 + 1], X[3 * v2 + 2]);
  // a . (b x c): the products of two floats are exact, the rest rounds per operation.
  const real cx = r_sub(r_prod(b.y, c.z), r_prod(b.z, c.y));
  const real cy = r_sub(r_prod(b.z, c.x), r_prod(b.x, c.z));
  const real cz = r_sub(r_prod(b.x, c.y), r_prod(b.y, c.x));
  return r_add(r_add(r_mulf(cx, a.x), r_mulf(cy, a.y)), r_mulf(cz, a.z));
}

void main() {
  const uint l = gl_LocalInvocationID.x;
  real s = r_zero();
  if (NPART > 1) {
    const uint per = uint(pc.count), k = gl_WorkGroupID.x / per, j = gl_WorkGroupID.x % per;
    const uint e = uint(parts[PT_FACE_START + k + 1]);
    for (uint f = uint(parts[PT_FACE_START + k]) + j * gl_WorkGroupSize.x + l; f < e; f += per * gl_WorkGroupSize.x)
      s = r_add(s, face_volume(f));
  } else {
    const uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    for (uint f = gl_GlobalInvocationID.x; f < uint(NFACE); f += stride) s = r_add(s, face_volume(f));
  }
  s_sum[l] = s;
  barrier();
  for (uint h = 128; h > 0; h >>= 1) {
    if (l < h) s_sum[l] = r_add(s_sum[l], s_sum[l + h]);
    barrier();
  }
  if (l == 0) red[pc.slot * RED_STRIDE + int(gl_WorkGroupID.x)] = r_div(s_sum[0], r_f(6.0));
}
