#version 450
// Exclusive prefix sum of scan_buf[0, pc.count), in place, by one workgroup: each
// invocation sums a contiguous run, the run totals are scanned, then each run is
// written. Used for the radix sort (radix.comp)'s digit counts and for the cells' tile counts.
#include "common.glsl"
layout(local_size_x = VPFFD_GROUP) in;
shared uint s_sum[VPFFD_GROUP];

void main() {
  const uint l = gl_LocalInvocationID.x, n = uint(pc.count);
  const uint per = (n + VPFFD_GROUP - 1) / VPFFD_GROUP;
  const uint b = min(l * per, n), e = min(b + per, n);
  uint s = 0u;
  for (uint i = b; i < e; ++i) s += scan_buf[i];
  s_sum[l] = s;
  barrier();
  if (l == 0) {
    uint acc = 0u;
    for (int i = 0; i < VPFFD_GROUP; ++i) {
      const uint t = s_sum[i];
      s_sum[i] = acc;
      acc += t;
    }
  }
  barrier();
  uint acc = s_sum[l];
  for (uint i = b; i < e; ++i) {
    const uint t = scan_buf[i];
    scan_buf[i] = acc;
    acc += t;
  }
}
