// The buffer layout of the displaced-subdivision-surface frame (subdiv.comp,
// VulkanSubdivFrame), defined once for GLSL and C++ like multires_layout.h: its own
// descriptor set; it shares only the device with the other frames.
#ifndef VPFFD_VULKAN_SUBDIV_LAYOUT_H
#define VPFFD_VULKAN_SUBDIV_LAYOUT_H

// Storage buffers of set 0, in binding order.
#define VPFFD_SD_B_C 0        // 3M float: control points, relative to the origin, in scale units
#define VPFFD_SD_B_PTR 1      // int, V + 1: CSR row starts of the stencils, one row per fine vertex
#define VPFFD_SD_B_IDX 2      // int, nnz: the control point of each stencil entry
#define VPFFD_SD_B_W 3        // real, 3 nnz: per entry w, w_u, w_v (interleaved)
#define VPFFD_SD_B_DATA 4     // float, SD_ROWS rows of V (SoA): d and the six coefficients
#define VPFFD_SD_B_X 5        // 3V float: fine vertices p', relative to the origin, in scale units
#define VPFFD_SD_B_N 6        // 3V float: approximate unit normals (eqs. 6-7)
#define VPFFD_SD_B_S 7        // 3V float: the limit points S'(t_i), relative to the origin, in scale units
#define VPFFD_SD_B_COUNT 8

#define VPFFD_SD_GROUP 256  // workgroup size

#ifdef __cplusplus
namespace vpffd::vulkan {
#endif

// Rows of the frame data, each V floats. d in scale units; the coefficients a, b
// (which multiply the tangents, now in scale units per patch parameter) times scale,
// g (which multiplies the unit normal) as it is: eqs. 6-7 then give the same tangents.
const int SD_D = 0;     // signed normal displacement d
const int SD_COEF = 1;  // 6 rows: a_u, b_u, g_u, a_v, b_v, g_v
const int SD_ROWS = 7;

#ifdef __cplusplus
}  // namespace vpffd::vulkan
#endif

#endif  // VPFFD_VULKAN_SUBDIV_LAYOUT_H
