// Shared declarations of the vpffd compute shaders.
//
// Precision: positions, control points and basis values are float32 (the
// positions are stored relative to the lattice centre, so their rounding is
// relative to the mesh size, not to its distance from the world origin).
// Everything that is summed over many vertices or faces (face normal components,
// vertex weights, coefficients, volumes, offsets) is `real` (real.glsl): float64
// where the device has shaderFloat64, else float-float pairs. A float32 sum over
// ~1e6 faces would lose the 1e-6 relative volume target.
//
// All reductions have a fixed shape (fixed dispatch sizes, fixed loop orders,
// tree reductions in shared memory), so a frame gives bit-identical results on
// every run: no floating-point atomics anywhere.

#extension GL_GOOGLE_include_directive : require
#include "real.glsl"
#include "layout.h"  // bindings, workgroup sizes, buffer offsets (shared with the C++ side)

#define KMAX 6  // order (degree + 1) of a degree-5 spline

// Sizes are specialization constants: fixed per Deformer, and they let the
// compiler unroll the basis loops for the lattice's orders.
layout(constant_id = 0) const int KU = 4;
layout(constant_id = 1) const int KV = 4;
layout(constant_id = 2) const int KW = 4;
layout(constant_id = 3) const int NU = 4;
layout(constant_id = 4) const int NV = 4;
layout(constant_id = 5) const int NW = 4;
layout(constant_id = 6) const int NVERT = 1;
layout(constant_id = 7) const int NFACE = 1;
layout(constant_id = 8) const int NTILE = 1;
layout(constant_id = 9) const int POLY_V = 0;  // start of axis v's span table in `poly`
layout(constant_id = 10) const int POLY_W = 0;
// Periodic axes (lattice/periodic.h): NDIST distinct control points (0: none, the
// lattice has no ties); per axis a seam, 2 bits each at bit 2a (SEAM_NONE, SEAM_SHIFT,
// SEAM_CLOSED or SEAM_TWIST); SEAM_KINDS: bit 1 << kind for each kind present.
layout(constant_id = 11) const int NDIST = 0;
layout(constant_id = 12) const int SEAMS = 0;
layout(constant_id = 13) const int SEAM_KINDS = 0;
layout(constant_id = 14) const int NPART = 1;  // parts, each keeping its own volume (1: the whole mesh)

const int NCP = NU * NV * NW;     // control points of the (extended) lattice the spline evaluates
const int KKK = KU * KV * KW;
// (Plain comparisons only: glslang's optimiser fails on || of specialisation constants.)
const bool TIED = NDIST > 0;
const int NDC = TIED ? NDIST : NCP;  // the control points a frame solves for (alpha, inv_w, delta rows)
// The cell sort's keys: part * NCP + cell, so each part's slots are one range of sorted
// positions and no tile straddles two parts (one part: the cell).
const int NKEY = NPART * NCP;
const bool ANY_SHIFT = (SEAM_KINDS & (1 << SEAM_SHIFT)) != 0;
const bool ANY_TWIST = (SEAM_KINDS & (1 << SEAM_TWIST)) != 0;
int seam_of(int a) { return (SEAMS >> (2 * a)) & 0x3; }

layout(push_constant) uniform Push {
  int axis;   // 0, 1, 2
  int step;   // index of the axis step in this frame
  int left;   // axis steps left including this one (the share divisor)
  int flags;  // bit 2: cone weights (an open mesh); bit 8: normals of P + delta (rows 0-2)
  int slot;   // volume: region of `red` to write; gather: row of `delta` to add
  int count;  // unused (keeps the block's layout)
} pc;

layout(std430, set = 0, binding = VPFFD_B_P) readonly buffer BufP { float P[]; };       // 3N, relative to the origin
layout(std430, set = 0, binding = VPFFD_B_X) buffer BufX { float X[]; };                // 3V, relative to the origin
layout(std430, set = 0, binding = VPFFD_B_F) readonly buffer BufF { int F[]; };         // 3F, sorted numbering
layout(std430, set = 0, binding = VPFFD_B_ADJ_PTR) readonly buffer BufAdjPtr { int adj_ptr[]; };
layout(std430, set = 0, binding = VPFFD_B_ADJ) readonly buffer BufAdj { int adj_face[]; };
// Written by embed.comp, read by every per-vertex pass.
layout(std430, set = 0, binding = VPFFD_B_SPAN) buffer BufSpan { int span[]; };   // 3V: first control index per axis
layout(std430, set = 0, binding = VPFFD_B_TAU) buffer BufTau { float tau[]; };   // 3V
layout(std430, set = 0, binding = VPFFD_B_POLY) readonly buffer BufPoly { float poly[]; };
layout(std430, set = 0, binding = VPFFD_B_TILES) buffer BufTile { ivec4 tiles[]; };  // start, count, cell, - (tiles.comp)
layout(std430, set = 0, binding = VPFFD_B_PARTIAL) buffer BufPart { real partial[]; };       // NTILE x KKK
layout(std430, set = 0, binding = VPFFD_B_TILE_VOL) buffer BufTileVol { real tile_vol[]; };  // NTILE
// The device embedding (embed.comp, radix.comp, tiles.comp): the digit counts of the
// cell sort, then per cell (= its first control point index) its first tile, N + 1 entries.
layout(std430, set = 0, binding = VPFFD_B_SCAN) buffer BufScan { uint scan_buf[]; };
// Rest positions (3V, device units, in the caller's vertex order: slot v's is at
// 3 slot_vertex[v]) and the embedding table (EM_*).
layout(std430, set = 0, binding = VPFFD_B_REST) readonly buffer BufRest { real rest[]; };
layout(std430, set = 0, binding = VPFFD_B_SLOT_VERTEX) readonly buffer BufSlotVertex { int slot_vertex[]; };
// Two arrays of (cell, slot) pairs, 2V ints each (the sorted one is the first), then
// per cell the range [start, end) of its vertices in the sorted array (2N ints).
layout(std430, set = 0, binding = VPFFD_B_SORT) buffer BufSort { int sorted[]; };
const int CELL_RANGE = 4 * NVERT;
layout(std430, set = 0, binding = VPFFD_B_ALPHA) buffer BufAlpha { real alpha[]; };       // N
layout(std430, set = 0, binding = VPFFD_B_INV_W) readonly buffer BufInvW { real inv_w[]; };  // N, 0 = fixed
layout(std430, set = 0, binding = VPFFD_B_DELTA) buffer BufDelta { real delta[]; };  // 4N: 3 accumulated axes, this step's
// Frame parameters (the FR_/CI_/ST_ offsets of layout.h): reals.
layout(std430, set = 0, binding = VPFFD_B_FRAME) readonly buffer BufFrame { real frame[]; };
// The point constraints' block: uploaded when the constraint sources or the
// weights change, not per frame.
layout(std430, set = 0, binding = VPFFD_B_CONS_I) readonly buffer BufConsI { int cons_i[]; };
layout(std430, set = 0, binding = VPFFD_B_STATS) buffer BufStats { real stats[]; };
layout(std430, set = 0, binding = VPFFD_B_RED) buffer BufRed { real red[]; };  // per-workgroup volume partials
layout(std430, set = 0, binding = VPFFD_B_CONS_D) readonly buffer BufConsD { real cons_d[]; };
// Scratch vectors of the solve workgroup; coherent: its invocations exchange them.
layout(std430, set = 0, binding = VPFFD_B_WORK) coherent buffer BufWork { real work[]; };
// normals.comp: the rest vertex normals (3V, scaled to a largest component of 1;
// rest_normals.comp) and the deformed ones (3V).
layout(std430, set = 0, binding = VPFFD_B_NRM0) buffer BufNrm0 { float nrm0[]; };
layout(std430, set = 0, binding = VPFFD_B_NRM) writeonly buffer BufNrm { float nrm[]; };
// normals.comp: `poly` in reals (same layout), then per axis and span d tau / d y.
layout(std430, set = 0, binding = VPFFD_B_NRM_TAB) readonly buffer BufNrmTab { real nrm_tab[]; };
// Periodic ties (TIED only): per extended control point the distinct one it copies
// (NCP ints), then per distinct point its extended copies as a list: NDIST + 1
// offsets (from TIE_LIST), then the copies in increasing index (NCP ints).
layout(std430, set = 0, binding = VPFFD_B_TIES) readonly buffer BufTies { int ties[]; };
const int TIE_PTR = NCP;
const int TIE_LIST = NCP + NDIST + 1;
// Per vertex slot (embed.comp, with a "shift" or "twist" seam): the translation a
// shift seam adds to the image of the wrapped rest position (xyz, device units) and
// whether a twist seam mirrored it (w: 1 or 0).
layout(std430, set = 0, binding = VPFFD_B_SEAM) buffer BufSeam { vec4 seam[]; };
layout(std430, set = 0, binding = VPFFD_B_PARTS) readonly buffer BufParts { int parts[]; };
const int PT_SLOT = NPART + 1;  // parts[PT_SLOT + v]: the part of vertex slot v

// The distinct control point whose displacement extended control point c takes
// (a displacement is tied by a pure copy: no shift constant).
int tie(int c) { return TIED ? ties[c] : c; }


// Basis values of one axis at local parameter t: Horner on the span's power form
// (the core's layout: coefficient of tau^q of function r at [q][r]).
void eval_axis(int off, int K, int first, float t, out float b[KMAX]) {
  const int base = off + first * K * K;
  for (int r = 0; r < KMAX; ++r) {
    if (r >= K) { b[r] = 0.0; continue; }
    float v = poly[base + (K - 1) * K + r];
    for (int q = K - 2; q >= 0; --q) v = v * t + poly[base + q * K + r];
    b[r] = v;
  }
}

// Basis values of vertex v; returns its first control point index.
int vertex_basis(uint v, out float bu[KMAX], out float bv[KMAX], out float bw[KMAX]) {
  const int i0 = span[3 * v], j0 = span[3 * v + 1], k0 = span[3 * v + 2];
  eval_axis(0, KU, i0, tau[3 * v], bu);
  eval_axis(POLY_V, KV, j0, tau[3 * v + 1], bv);
  eval_axis(POLY_W, KW, k0, tau[3 * v + 2], bw);
  return (i0 * NV + j0) * NW + k0;
}

// Component `a` of face f's unnormalised normal (p1 - p0) x (p2 - p0): the edge
// vectors are exact (differences of two floats), the rest rounds once per operation.
real face_normal(int f, int a) {
  const int a1 = (a + 1) % 3, a2 = (a + 2) % 3;
  const int v0 = F[3 * f], v1 = F[3 * f + 1], v2 = F[3 * f + 2];
  const real p0a = r_f(X[3 * v0 + a1]), p0b = r_f(X[3 * v0 + a2]);
  const real e1a = r_sub(r_f(X[3 * v1 + a1]), p0a), e1b = r_sub(r_f(X[3 * v1 + a2]), p0b);
  const real e2a = r_sub(r_f(X[3 * v2 + a1]), p0a), e2b = r_sub(r_f(X[3 * v2 + a2]), p0b);
  return r_sub(r_mul(e1a, e2b), r_mul(e1b, e2a));
}

// Face f's contribution to the weight of its corner c for an open mesh: the exact
// gradient of the cone volume from the origin, ((x_m - o) x (x_n - o))_a with m, n
// the next corners (positions are already relative to the origin).
real cone_weight(int f, int c, int a) {
  const int a1 = (a + 1) % 3, a2 = (a + 2) % 3;
  const int m = F[3 * f + (c + 1) % 3], n = F[3 * f + (c + 2) % 3];
  return r_sub(r_prod(X[3 * m + a1], X[3 * n + a2]), r_prod(X[3 * m + a2], X[3 * n + a1]));
}
