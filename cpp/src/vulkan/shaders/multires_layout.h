// The buffer layout of the multiresolution frame (multires.comp, VulkanMultires),
// defined once for GLSL and C++ like layout.h: its own descriptor set, since it shares
// only the device with a VulkanDeformer, not its buffers (a frame after a Deformer's
// copies that Deformer's control points and offsets into SRC_P and SRC_DELTA).
#ifndef VPFFD_VULKAN_MULTIRES_LAYOUT_H
#define VPFFD_VULKAN_MULTIRES_LAYOUT_H

// Storage buffers of set 0, in binding order. N: control points of the lattice the
// spline evaluates (a periodic lattice's extended one), NDIST: those a frame solves for.
#define VPFFD_MR_B_P 0      // 3N float: control points, relative to the origin, in scale units
#define VPFFD_MR_B_TAB 1    // real: per-span power forms of the three axes, then per axis and
                            // span d tau / d y in device units (normals.comp's nrm_tab layout)
#define VPFFD_MR_B_SPAN 2   // int, 3 rows of V (SoA): first control index per axis of the foot point
#define VPFFD_MR_B_DATA 3   // float, MR_ROWS rows of V (SoA): the per-vertex frame data (MR_*)
#define VPFFD_MR_B_X 4      // 3V float: fine vertices p', relative to the origin, in scale units
#define VPFFD_MR_B_N 5      // 3V float: approximate unit normals (eqs. 6-7)
#define VPFFD_MR_B_SRC_P 6  // 3N float: a VulkanDeformer's control points of the frame (same units)
#define VPFFD_MR_B_SRC_DELTA 7  // 3 NDIST real: its offsets, row a = axis a (delta rows 0-2, layout.h)
#define VPFFD_MR_B_TIES 8   // int, N: per extended control point the distinct one it copies (periodic
                            // lattices; a placeholder otherwise)
#define VPFFD_MR_B_COUNT 9

#define VPFFD_MR_GROUP 256  // workgroup size

#ifdef __cplusplus
namespace vpffd::vulkan {
#endif

// Rows of the frame data, each V floats (device vertex order). Lengths in scale units;
// the coefficients a, b (1 / length) times scale, g as they are (eqs. 6-7 then give the
// same tangents).
const int MR_TAU = 0;    // 3 rows: the foot point's local parameters
const int MR_SU = 3;     // 3 rows: S_u
const int MR_SV = 6;     // 3 rows: S_v
const int MR_D = 9;      // signed normal displacement d
const int MR_COEF = 10;  // 6 rows: a_u, b_u, g_u, a_v, b_v, g_v
const int MR_ROWS = 16;
// A periodic lattice with a "shift" seam: 3 more rows, the translation the seam adds to
// the image of the wrapped foot point (lattice/periodic.h). A "twist" seam's mirror of
// J is folded into S_u and S_v on the host (J M t = J (M t), exact sign changes).
const int MR_SHIFT = 16;
const int MR_ROWS_SHIFTED = 19;

#ifdef __cplusplus
}  // namespace vpffd::vulkan
#endif

#endif  // VPFFD_VULKAN_MULTIRES_LAYOUT_H
