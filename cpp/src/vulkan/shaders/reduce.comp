#version 450
// stats[slot] = sum (flags bit 1 clear) or max (set) of red[0 .. count), fixed order.
#include "common.glsl"
layout(local_size_x = 256) in;
shared double s_acc[256];

void main() {
  const uint l = gl_LocalInvocationID.x;
  const bool is_max = (pc.flags & 2) != 0;
  double s = 0.0;
  for (uint i = l; i < uint(pc.count); i += 256) s = is_max ? max(s, red[i]) : s + red[i];
  s_acc[l] = s;
  barrier();
  for (uint h = 128; h > 0; h >>= 1) {
    if (l < h) s_acc[l] = is_max ? max(s_acc[l], s_acc[l + h]) : s_acc[l] + s_acc[l + h];
    barrier();
  }
  if (l == 0) stats[pc.slot] = s_acc[0];
}
