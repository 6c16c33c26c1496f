#version 450
// The rest of one axis step once `combine` has the volume coefficients alpha: the
// closed-form offsets and their application to the accumulated offsets, in one
// workgroup (one dispatch instead of solve, offsets and max-reduce passes).
//
// minimise sum_c w_c delta_c^2 subject to alpha . delta = share (the step's share of
// the missing volume) and B(u_s) . delta = b_s per point constraint s:
// delta = W^-1 R^T lambda with G lambda = b, G = [[g00, g^T], [g, C]],
// g00 = alpha W^-1 alpha, g_s = B(u_s) W^-1 alpha and C = R_c W^-1 R_c^T.
// C does not depend on the mesh, so the host factors it once per constraint set
// (C^-1 arrives in cons_d, with C's checks done as the CPU backend does them) and
// the device eliminates the volume row (Schur complement s = g00 - g^T C^-1 g):
// O(nc^2) per step instead of an eigen-decomposition of the (nc+1)^2 matrix, and
// every sum is spread over the workgroup. One refinement step on the residual of
// G lambda = b follows, as on the CPU.
//
// b_s is measured where the constraint point is now (the host's target - B(u_s) . P
// minus B(u_s) . the offsets of earlier steps), so later rounds only correct rounding.
// Failures are written as a status the host turns into the CPU's SolverError.
//
// On a periodic lattice the unknowns are the distinct control points (NDC of them,
// correction/tied_solve.h): alpha arrives folded (combine.comp), a constraint row's
// extended entries read their distinct point through tie(), and the host's block
// (constraint_block.cpp) holds the folded rows.
#include "common.glsl"
layout(local_size_x = VPFFD_GROUP) in;
const int WG = VPFFD_GROUP;

shared real s_a[WG];
shared real s_b[WG];
shared real s_c[WG];

// Workgroup sums of three values in a fixed tree order; every invocation gets them.
void sum3(inout real a, inout real b, inout real c) {
  const uint l = gl_LocalInvocationID.x;
  s_a[l] = a;
  s_b[l] = b;
  s_c[l] = c;
  barrier();
  for (uint h = WG / 2; h > 0; h >>= 1) {
    if (l < h) {
      s_a[l] = r_add(s_a[l], s_a[l + h]);
      s_b[l] = r_add(s_b[l], s_b[l + h]);
      s_c[l] = r_add(s_c[l], s_c[l + h]);
    }
    barrier();
  }
  a = s_a[0];
  b = s_b[0];
  c = s_c[0];
  barrier();
}

// The workgroup's writes to `work` are visible to all its invocations after this.
void sync_work() {
  memoryBarrierBuffer();
  barrier();
}

void main() {
  const int l = int(gl_LocalInvocationID.x);
  const int ax = pc.axis;
  const int nc = cons_i[CI_NC];
  const int st = ST_STEP + pc.step * ST_STEP_STRIDE;
  const int H = cons_i[CI_H], G = cons_i[CI_G];
  // work: g, b, C^-1 g, C^-1 b (later C^-1 r), lambda_c, r (nc each)
  const int W_G = 0, W_B = nc, W_Y = 2 * nc, W_Z = 3 * nc, W_L = 4 * nc, W_R = 5 * nc;

  real vol = r_zero(), g00 = r_zero(), s2 = r_zero();
  for (int i = l; i < NTILE; i += WG) vol = r_add(vol, tile_vol[i]);
  for (int c = l; c < NDC; c += WG) {
    const real a = alpha[c];
    const real a2 = r_mul(a, a);
    g00 = r_add(g00, r_mul(a2, inv_w[c]));
    s2 = r_add(s2, a2);
  }
  sum3(vol, g00, s2);
  const real share = r_div(r_sub(frame[FR_TARGET], vol), r_f(float(pc.left)));

  // Every invocation derives status from the same sums: the branches below are uniform.
  int status = 0;
  real detail = r_zero(), lam0 = r_zero();
  // A zero row means nothing free can move the volume; relative to the unweighted norm.
  if (!(r_hi(g00) > R_TINY) || !(r_hi(g00) > scal(1e-24) * r_hi(s2) * r_hi(frame[FR_MAX_INVW]))) status = 1;
  if (status == 0) {
    for (int s = l; s < nc; s += WG) {
      const int base = cons_i[CI_BASE + s];
      real g = r_zero(), moved = r_zero();
      int o = s * KKK;
      for (int i = 0; i < KU; ++i)
        for (int j = 0; j < KV; ++j)
          for (int k = 0; k < KW; ++k, ++o) {
            const int c = tie(base + (i * NV + j) * NW + k);
            const real r = cons_d[o];
            g = r_add(g, r_mul(r_mul(r, inv_w[c]), alpha[c]));
            moved = r_add(moved, r_mul(r, delta[ax * NDC + c]));
          }
      work[W_G + s] = g;
      work[W_B + s] = r_sub(frame[FR_RHS + ax * nc + s], moved);
    }
    sync_work();
    for (int p = l; p < nc; p += WG) {
      real y = r_zero(), z = r_zero();
      for (int q = 0; q < nc; ++q) {
        const real h = cons_d[H + p * nc + q];
        y = r_add(y, r_mul(h, work[W_G + q]));
        z = r_add(z, r_mul(h, work[W_B + q]));
      }
      work[W_Y + p] = y;
      work[W_Z + p] = z;
    }
    sync_work();
    real gy = r_zero(), gz = r_zero(), unused = r_zero();
    for (int s = l; s < nc; s += WG) {
      gy = r_add(gy, r_mul(work[W_G + s], work[W_Y + s]));
      gz = r_add(gz, r_mul(work[W_G + s], work[W_Z + s]));
    }
    sum3(gy, gz, unused);
    const real schur = r_sub(g00, gy);
    // schur / g00 is the Schur complement of the unit-diagonal G, an upper bound of its
    // smallest eigenvalue: the CPU's test lo > 1e-12 hi fails whenever this one does.
    // detail: the condition number, or -1 for infinite.
    const real hi = frame[FR_HI];
    if (!(r_hi(schur) > scal(1e-12) * r_hi(hi) * r_hi(g00))) {
      status = 3;
      detail = r_hi(schur) > 0.0 ? r_div(r_mul(hi, g00), schur) : r_f(-1.0);
    } else {
      lam0 = r_div(r_sub(share, gz), schur);
      for (int p = l; p < nc; p += WG) work[W_L + p] = r_sub(work[W_Z + p], r_mul(work[W_Y + p], lam0));
      sync_work();
      // Residual of G lambda = b, then the same elimination on it.
      real gl = r_zero(), u0 = r_zero(), u1 = r_zero();
      for (int p = l; p < nc; p += WG) {
        real r = r_sub(work[W_B + p], r_mul(work[W_G + p], lam0));
        for (int q = 0; q < nc; ++q) r = r_sub(r, r_mul(cons_d[G + p * nc + q], work[W_L + q]));
        work[W_R + p] = r;
        gl = r_add(gl, r_mul(work[W_G + p], work[W_L + p]));
      }
      sum3(gl, u0, u1);
      const real r0 = r_sub(r_sub(share, r_mul(g00, lam0)), gl);
      sync_work();
      for (int p = l; p < nc; p += WG) {
        real z = r_zero();
        for (int q = 0; q < nc; ++q) z = r_add(z, r_mul(cons_d[H + p * nc + q], work[W_R + q]));
        work[W_Z + p] = z;
      }
      sync_work();
      real gz2 = r_zero();
      for (int s = l; s < nc; s += WG) gz2 = r_add(gz2, r_mul(work[W_G + s], work[W_Z + s]));
      sum3(gz2, u0, u1);
      const real d0 = r_div(r_sub(r0, gz2), schur);
      lam0 = r_add(lam0, d0);
      for (int p = l; p < nc; p += WG)
        work[W_L + p] = r_add(work[W_L + p], r_sub(work[W_Z + p], r_mul(work[W_Y + p], d0)));
      sync_work();
    }
  }

  // delta = W^-1 (lambda_0 alpha + sum_s lambda_s B(u_s)), per control point through
  // its list of constraint entries (O(nc K^3) in all, not O(nc N)).
  real mx = r_zero();
  const int ptr = cons_i[CI_PTR], idx = cons_i[CI_IDX];
  for (int c = l; c < NDC; c += WG) {
    real d = r_zero();
    const real iw = inv_w[c];
    if (status == 0 && r_hi(iw) > 0.0) {
      real s = r_mul(lam0, alpha[c]);
      for (int p = cons_i[ptr + c]; p < cons_i[ptr + c + 1]; ++p) {
        const int e = cons_i[idx + p];
        s = r_add(s, r_mul(work[W_L + e / KKK], cons_d[e]));
      }
      d = r_mul(iw, s);
    }
    delta[3 * NDC + c] = d;
    delta[ax * NDC + c] = r_add(delta[ax * NDC + c], d);
    mx = r_max(mx, r_abs(d));
  }
  s_a[l] = mx;
  barrier();
  for (int h = WG / 2; h > 0; h >>= 1) {
    if (l < h) s_a[l] = r_max(s_a[l], s_a[l + h]);
    barrier();
  }
  if (l == 0) {
    stats[st] = vol;
    stats[st + 1] = share;
    stats[st + 2] = g00;
    stats[st + 3] = s_a[0];
    stats[st + 4] = r_f(float(status));
    stats[st + 5] = detail;
  }
}
