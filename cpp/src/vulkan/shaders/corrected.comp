#version 450
// The control points of a multiresolution frame that follows a VulkanDeformer's frame
// in the same submission (VulkanMultires::deform with a Deformer): P plus, when
// pc.corrected is set, the Deformer's accumulated offsets (delta rows 0-2, reals),
// summed in reals and rounded once to float32, the precision multires.comp reads.
// Both sides share origin and scale (the lattice's), so no change of units. One
// invocation per control point of the extended lattice; a periodic lattice's offsets are
// the distinct points', copied to their tied ones through the tie map (no seam constant:
// the Deformer's control points already carry it).
#extension GL_GOOGLE_include_directive : require
#include "real.glsl"
#include "multires_layout.h"

// The specialisation constants of multires.comp (only the lattice's dimensions are used).
layout(constant_id = 3) const int NU = 4;
layout(constant_id = 4) const int NV = 4;
layout(constant_id = 5) const int NW = 4;
layout(constant_id = 9) const int NDIST = 0;
const int NCP = NU * NV * NW;
const bool TIED = NDIST > 0;
const int NDC = TIED ? NDIST : NCP;  // columns of the offsets' rows

layout(local_size_x = VPFFD_MR_GROUP) in;

layout(push_constant) uniform Push { int corrected; } pc;

layout(std430, set = 0, binding = VPFFD_MR_B_P) writeonly buffer BufP { float P[]; };
layout(std430, set = 0, binding = VPFFD_MR_B_SRC_P) readonly buffer BufSrcP { float src[]; };
layout(std430, set = 0, binding = VPFFD_MR_B_SRC_DELTA) readonly buffer BufSrcDelta { real delta[]; };
layout(std430, set = 0, binding = VPFFD_MR_B_TIES) readonly buffer BufTies { int ties[]; };

void main() {
  const uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
  for (uint c = gl_GlobalInvocationID.x; c < uint(NCP); c += stride) {
    const int e = TIED ? ties[c] : int(c);
    for (int a = 0; a < 3; ++a) {
      const float p = src[3 * c + a];
      P[3 * c + a] = pc.corrected != 0 ? r_to_float(r_add(r_f(p), delta[a * NDC + e])) : p;
    }
  }
}
