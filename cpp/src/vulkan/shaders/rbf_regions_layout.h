// The buffer layout of the RBF regions frame (rbf_regions.comp, VulkanRbfFrame),
// defined once for GLSL and C++ like subdiv_layout.h: its own descriptor set; it
// shares only the device with the other frames.
#ifndef VPFFD_VULKAN_RBF_REGIONS_LAYOUT_H
#define VPFFD_VULKAN_RBF_REGIONS_LAYOUT_H

// Storage buffers of set 0, in binding order.
#define VPFFD_RB_B_MAPS 0    // real, RB_MAP_REALS per region: the K maps in device units (per frame)
#define VPFFD_RB_B_LAB 1     // int, 2V: per vertex its label (-1 fixed, 0 free, k handle region) and free slot f
#define VPFFD_RB_B_PTS 2     // real, RB_PTS rows of V (SoA): the rest points, device units
#define VPFFD_RB_B_BASIS 3   // real, 16 K per free vertex: the RBF basis alpha_k in device units
#define VPFFD_RB_B_DATA 4    // float, RB_ROWS rows of V (SoA): d, the six coefficients, the rest normal
#define VPFFD_RB_B_X 5       // 3V float: fine vertices p', relative to the origin, in scale units
#define VPFFD_RB_B_N 6       // 3V float: unit normals
#define VPFFD_RB_B_B 7       // 3V float: base vertices, relative to the origin, in scale units
#define VPFFD_RB_B_COUNT 8

#define VPFFD_RB_GROUP 256  // workgroup size

#ifdef __cplusplus
namespace vpffd::vulkan {
#endif

// Rows of the rest points, each V reals (device units: (x - origin) / scale for
// points, x / scale for tangents). Free vertices: the foot point S, the tangents S_u,
// S_v and the base vertex; handle and fixed vertices: the fine vertex in rows 0-2,
// rows 3-8 unused (zero), the base vertex in rows 9-11.
const int RB_S = 0;   // 3 rows
const int RB_SU = 3;  // 3 rows
const int RB_SV = 6;  // 3 rows
const int RB_Q = 9;   // 3 rows: the base vertex
const int RB_PTS = 12;

// Rows of the float data, each V floats: d in scale units; a, b (multiplying tangents
// in scale units) times scale; g as it is; the unit rest normal.
const int RB_D = 0;
const int RB_COEF = 1;  // 6 rows: a_u, b_u, g_u, a_v, b_v, g_v
const int RB_NRM = 7;   // 3 rows
const int RB_ROWS = 10;

// Per region k, RB_MAP_REALS reals at k * RB_MAP_REALS: the displacement multiplying
// alpha (3 x 4 row-major: D_1 for k = 0, D_{k+1} - D_1 otherwise, device units), the
// map T_{k+1} itself (3 x 4 row-major, device units) and cof(A_{k+1}) (3 x 3 row-major).
const int RB_MAP_D = 0;
const int RB_MAP_T = 12;
const int RB_MAP_COF = 24;
const int RB_MAP_REALS = 33;

#ifdef __cplusplus
}  // namespace vpffd::vulkan
#endif

#endif  // VPFFD_VULKAN_RBF_REGIONS_LAYOUT_H
