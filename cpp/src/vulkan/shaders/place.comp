#version 450
// The frame's vertices (pc.slot 0) or normals (pc.slot 1) in the caller's vertex order,
// ready for the host to take as they are: caller vertex j is device slot
// slot_vertex[NVERT + j], so each invocation gathers one vertex's three values and
// writes them in order (every output written once, by one invocation, so the result
// does not depend on scheduling; a gather, not a scatter: a CPU driver such as
// lavapipe vectorises gathers and writes in order, where scattered stores run one lane
// at a time). The host then copies memory in order instead of reordering it.
//
// float64 build: world coordinates x * scale + origin in double, the very arithmetic of
// the host's conversion (VulkanDeformer::Impl::unpack): the float32 value widened
// exactly, times a power of two (exact), one correctly rounded addition, so the bits
// are the host's (a fused multiply-add would give them too, the product being exact).
// Normals take scale 1 and origin 0 as the host does (-0 + 0 = +0 included: `precise`
// keeps the addition). float-float build (devices without shaderFloat64): the float32
// values in the caller's order; the host widens them in one pass in order.
//
// Standalone, not common.glsl: this pass reads `nrm`, which the others only write.
#extension GL_GOOGLE_include_directive : require
#include "real.glsl"
#include "layout.h"
layout(local_size_x = VPFFD_GROUP) in;

layout(constant_id = 6) const int NVERT = 1;

layout(push_constant) uniform Push {
  int axis, step, left, flags;
  int slot;  // 0: the vertices, 1: the normals (into the second region of `placed`)
  int count;
} pc;

layout(std430, set = 0, binding = VPFFD_B_X) readonly buffer BufX { float X[]; };
layout(std430, set = 0, binding = VPFFD_B_NRM) readonly buffer BufNrm { float nrm[]; };
layout(std430, set = 0, binding = VPFFD_B_SLOT_VERTEX) readonly buffer BufSlotVertex { int slot_vertex[]; };
layout(std430, set = 0, binding = VPFFD_B_FRAME) readonly buffer BufFrame { real frame[]; };
#ifdef VPFFD_FLOAT_FLOAT
layout(std430, set = 0, binding = VPFFD_B_PLACED) writeonly buffer BufPlaced { float placed[]; };
#else
layout(std430, set = 0, binding = VPFFD_B_PLACED) writeonly buffer BufPlaced { double placed[]; };

// The float32 value as a double, float32 subnormals included: a device may flush them
// in a conversion (nothing asks for shaderDenormPreserveFloat32), the host does not.
double widen(float x) {
  const uint b = floatBitsToUint(x);
  if ((b & 0x7f800000u) != 0u) return double(x);  // normal, infinite or NaN: exact
  const double two_m149 = packDouble2x32(uvec2(0u, uint(1023 - 149) << 20));  // 2^-149, a normal double
  const double m = double(int(b & 0x007fffffu)) * two_m149;  // exact: 23 bits times a power of two
  return (b >> 31) != 0u ? -m : m;
}
#endif

void main() {
  const bool normals = pc.slot == 1;
  const uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
  const int region = normals ? 3 * NVERT : 0;
#ifndef VPFFD_FLOAT_FLOAT
  const double s = normals ? 1.0LF : frame[FR_SCALE];
  const dvec3 o = normals ? dvec3(0.0LF) : dvec3(frame[FR_ORIGIN], frame[FR_ORIGIN + 1], frame[FR_ORIGIN + 2]);
#endif
  for (uint j = gl_GlobalInvocationID.x; j < uint(NVERT); j += stride) {
    const int v = slot_vertex[NVERT + j];
    const int dst = region + 3 * int(j);
    for (int a = 0; a < 3; ++a) {
      const float x = normals ? nrm[3 * v + a] : X[3 * v + a];
#ifdef VPFFD_FLOAT_FLOAT
      placed[dst + a] = x;
#else
      precise double w = widen(x) * s + o[a];
      placed[dst + a] = w;
#endif
    }
  }
}
