// The device buffers' layout, defined once: included by the shaders (common.glsl) and
// by the C++ side of the backend (deformer_impl.h). Written in the part of the C
// preprocessor and declaration syntax that GLSL and C++ share, so the two cannot
// drift apart: binding numbers, workgroup sizes and the offsets inside the frame,
// constraint and step-result buffers.
#ifndef VPFFD_VULKAN_LAYOUT_H
#define VPFFD_VULKAN_LAYOUT_H

// Storage buffers of set 0, in binding order (the C++ Buf enum takes these values).
#define VPFFD_B_P 0           // 3N float: control points, relative to the origin, in scale units
#define VPFFD_B_X 1           // 3V float: vertices, same units
#define VPFFD_B_F 2           // 3F int: faces, device numbering
#define VPFFD_B_ADJ_PTR 3     // vertex-face adjacency (CSR)
#define VPFFD_B_ADJ 4
#define VPFFD_B_SPAN 5        // 3V int: first control index per axis
#define VPFFD_B_TAU 6         // 3V float: local parameters
#define VPFFD_B_POLY 7        // float: per-span power forms of the three axes
#define VPFFD_B_TILES 8       // ivec4 per tile: start (sorted position), count, cell (first control point), -
#define VPFFD_B_PARTIAL 9     // real, NTILE x KKK: tile partials of the coefficients
#define VPFFD_B_TILE_VOL 10   // real, NTILE
#define VPFFD_B_SCAN 11       // uint: radix-sort digit counts, then per cell its first tile (N + 1)
#define VPFFD_B_REST 12       // real: 3V rest positions (the caller's vertex order; scale units, from the origin),
                             // then the embedding table
#define VPFFD_B_ALPHA 13      // real, N: coefficients
#define VPFFD_B_INV_W 14      // real, N: inverse weights, 0 = fixed
#define VPFFD_B_DELTA 15      // real, 4N: three accumulated axes, this step's
#define VPFFD_B_FRAME 16      // real: frame parameters (FR_*)
#define VPFFD_B_CONS_I 17     // int: constraint block indices (CI_*)
#define VPFFD_B_STATS 18      // real: step results (ST_*)
#define VPFFD_B_RED 19        // real: per-workgroup volume partials, RED_STRIDE per slot
#define VPFFD_B_CONS_D 20     // real: constraint block values
#define VPFFD_B_WORK 21       // real: scratch of the solve workgroup
#define VPFFD_B_NRM0 22       // 3V float: rest vertex normals
#define VPFFD_B_NRM 23        // 3V float: deformed vertex normals
#define VPFFD_B_NRM_TAB 24    // real: power forms and derivative scales for normals.comp
#define VPFFD_B_SORT 25       // int: two (cell, slot) arrays of 2V (the sort's ping-pong), then (start, end) per cell
#define VPFFD_B_TIES 26       // int: periodic tie map (common.glsl TIE_*)
#define VPFFD_B_SEAM 27       // vec4 per vertex slot: shift seam translation, twist seam mirror flag
#define VPFFD_B_PARTS 28      // int, with parts: each part's faces [PT_FACE_START + k, + k + 1), each slot's part
#define VPFFD_B_SLOT_VERTEX 29  // int, 2V: the caller's vertex of each slot (where its rest position is in
                               // rest[]), then the slot of each caller vertex (place.comp)
#define VPFFD_B_PLACED 30     // place.comp's output in the caller's vertex order: 3V vertices, then 3V
                             // normals (double in the float64 build, float in the float-float one)
#define VPFFD_B_COUNT 31

// Workgroup sizes.
#define VPFFD_TILE 64         // vertices per tile = coef.comp's workgroup size
#define VPFFD_GROUP 256       // every other pass
#define VPFFD_RED_STRIDE 1024 // the most workgroups of a grid-stride pass (fixed reduction shape)
#define VPFFD_SORT_BLOCK 1024 // vertices per workgroup of the radix sort's count and scatter passes
#define VPFFD_SORT_DIGITS 256 // radix of the sort: 8 bits per pass (= VPFFD_GROUP: one invocation per digit)

#ifdef __cplusplus
namespace vpffd::vulkan {
#endif

const int RED_STRIDE = VPFFD_RED_STRIDE;
// frame[]: reals.
const int FR_TARGET = 0;
const int FR_MAX_INVW = 1;
const int FR_HI = 2;          // largest eigenvalue of the unit-diagonal constraint block (>= 1)
const int FR_SCALE = 3;       // world units per device unit (a power of two; place.comp)
const int FR_ORIGIN = 4;      // 3: the origin of device positions in world units (place.comp)
const int FR_RHS = 8;         // 3 x nc, axis-major: target - B(u_s) . P along the axis; then with
                              // parts their K target volumes (FR_RHS + 3 nc + k)
// cons_i[]: ints.
const int CI_NC = 0;
const int CI_PTR = 1;         // offset of the per-control-point lists (N + 1 entries)
const int CI_IDX = 2;         // offset of their entries: s * KKK + local index into cons_d
const int CI_G = 3;           // offset in cons_d of G_cc = R W^-1 R^T (nc x nc)
const int CI_H = 4;           // offset in cons_d of G_cc^-1 (nc x nc)
const int CI_BASE = 8;        // nc first control point indices; cons_d starts with nc x KKK row values
// rest[]: reals after the 3V positions: the parameter map u = EM_U0[a] + y EM_DU[a] per
// axis (y in device units); the box per axis (device units): its low and high faces, its
// extent and lo + hi (a twist seam's mirror: y -> EM_MID - y); then the knot vectors of
// the three axes (dims + order each); then 3 K reals, the translation of each part's
// rest positions (device units) that embed.comp adds with EM_OFFSET (set_rest_offsets).
const int EM_U0 = 0;
const int EM_DU = 3;
const int EM_LO = 6;
const int EM_HI = 9;
const int EM_EXT = 12;
const int EM_MID = 15;
const int EM_KNOTS = 18;
// Seams per axis in the SEAMS specialisation constant (2 bits per axis; Seam of lattice.h).
const int SEAM_NONE = 0;
const int SEAM_SHIFT = 1;
const int SEAM_CLOSED = 2;
const int SEAM_TWIST = 3;
// Push flags of embed.comp: clamp the parameter into the domain (outside = error).
const int EM_CLAMP = 1;
// and add each part's translation (after the knots in rest[]) to its slots' positions.
const int EM_OFFSET = 2;
// parts[]: ints (binding VPFFD_B_PARTS, with NPART > 1): the K + 1 face offsets of the
// parts (the faces are grouped by part), then the part of every vertex slot.
const int PT_FACE_START = 0;
// The most parts the device solve takes (an LDL^T of the K x K Schur complement by one
// invocation, solve.comp).
const int MAX_DEVICE_PARTS = 64;
// stats[]: reals. First each part's volume before the correction (one without parts),
// left by the first step's solve from its coefficient pass (device steps run no volume
// pass before them); then per step: volume_before, share, sum_squares, max_offset,
// status, detail.
const int ST_PART_BEFORE = 0;
const int ST_STEP = MAX_DEVICE_PARTS;
const int ST_STEP_STRIDE = 8;

#ifdef __cplusplus
}  // namespace vpffd::vulkan
#endif

#endif  // VPFFD_VULKAN_LAYOUT_H
