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

// ---- parts (NPART > 1): one volume row per part ------------------------------------
// minimise sum_c w_c delta_c^2 subject to alpha_k . delta = share_k for every part k
// (each part's share of what it still misses, as the CPU's solve_axis_offsets_parts)
// and B(u_s) . delta = b_s per point constraint. With G_vv the parts' K x K Gram
// matrix, G_vc their products with the constraint rows and C^-1 from the host, the
// constraints are eliminated: S = G_vv - G_vc C^-1 G_cv (K x K, K <= MAX_DEVICE_PARTS)
// is factored LDL^T by one invocation (O(K^3), small next to the O(K^2 N) Gram sums
// spread over the workgroup), S lambda_v = share - G_vc C^-1 b, lambda_c = C^-1 (b -
// G_cv lambda_v), then one refinement on the whole system's residual, as on the CPU.
// Statuses: 1 a part's row is zero at every free control point (detail: the part),
// 3 a pivot of the unit-diagonal S below 1e-12 (K + the constraint block's largest
// eigenvalue), a bound of the CPU's 1e-12 hi test: the host then asks the CPU backend
// for its message, which names the rows.
shared int s_status;
// Offsets in `work` (reals), set by solve_parts: per part k and constraint s,
// G_vc[k nc + s] (GV) and C^-1 G_cv (Y, same layout); nc-vectors B (b), Z, LC
// (lambda_c), RC (a residual), DC (a correction); K x K: VV (G_vv), S, FAC (L below the
// diagonal, the pivots on it); K-vectors VOL, SH (shares), LV (lambda_v), RV, DV, TV, N2
// (squared norms of the rows).
int GV, B, Y, Z, LC, RC, DC, VV, S, FAC, VOL, SH, LV, RV, DV, TV, N2;

// lv, lc = the solution of the system with right-hand sides rv (parts), rc (constraints).
void eliminate(int rv, int rc, int lv, int lc, int nc) {
  const int l = int(gl_LocalInvocationID.x), K = NPART, H = cons_i[CI_H];
  for (int p = l; p < nc; p += WG) {
    real z = r_zero();
    for (int q = 0; q < nc; ++q) z = r_add(z, r_mul(cons_d[H + p * nc + q], work[rc + q]));
    work[Z + p] = z;
  }
  sync_work();
  for (int k = l; k < K; k += WG) {
    real t = work[rv + k];
    for (int s = 0; s < nc; ++s) t = r_sub(t, r_mul(work[GV + k * nc + s], work[Z + s]));
    work[TV + k] = t;
  }
  sync_work();
  if (l == 0) {
    // L y = t, D x' = y, L^T x = x'.
    for (int i = 0; i < K; ++i) {
      real y = work[TV + i];
      for (int j = 0; j < i; ++j) y = r_sub(y, r_mul(work[FAC + i * K + j], work[lv + j]));
      work[lv + i] = y;
    }
    for (int i = 0; i < K; ++i) work[lv + i] = r_div(work[lv + i], work[FAC + i * K + i]);
    for (int i = K - 1; i >= 0; --i) {
      real x = work[lv + i];
      for (int j = i + 1; j < K; ++j) x = r_sub(x, r_mul(work[FAC + j * K + i], work[lv + j]));
      work[lv + i] = x;
    }
  }
  sync_work();
  for (int p = l; p < nc; p += WG) {
    real c = work[Z + p];
    for (int k = 0; k < K; ++k) c = r_sub(c, r_mul(work[Y + k * nc + p], work[lv + k]));
    work[lc + p] = c;
  }
  sync_work();
}

void solve_parts() {
  const int l = int(gl_LocalInvocationID.x);
  const int ax = pc.axis, K = NPART;
  const int nc = cons_i[CI_NC];
  const int st = ST_STEP + pc.step * ST_STEP_STRIDE;
  const int G = cons_i[CI_G];
  GV = 0; B = K * nc; Y = B + nc; Z = Y + K * nc; LC = Z + nc; RC = LC + nc; DC = RC + nc;
  VV = DC + nc; S = VV + K * K; FAC = S + K * K;
  VOL = FAC + K * K; SH = VOL + K; LV = SH + K; RV = LV + K; DV = RV + K; TV = DV + K; N2 = TV + K;

  // Each part's volume from its tiles (part k's: [scan_buf[k NCP], scan_buf[(k + 1) NCP]),
  // tiles.comp), and the Gram entries p <= q and the rows' squared norms, three per
  // workgroup sum, in a fixed order.
  for (int k0 = 0; k0 < K; k0 += 3) {
    real v[3];
    for (int j = 0; j < 3; ++j) {
      v[j] = r_zero();
      const int k = k0 + j;
      if (k >= K) continue;
      for (int t = int(scan_buf[k * NCP]) + l; t < int(scan_buf[(k + 1) * NCP]); t += WG) v[j] = r_add(v[j], tile_vol[t]);
    }
    sum3(v[0], v[1], v[2]);
    if (l == 0)
      for (int j = 0; j < 3 && k0 + j < K; ++j) work[VOL + k0 + j] = v[j];
  }
  const int items = K * K + K;
  for (int i0 = 0; i0 < items; i0 += 3) {
    real v[3];
    for (int j = 0; j < 3; ++j) {
      v[j] = r_zero();
      const int i = i0 + j;
      const bool norm = i >= K * K;
      const int p = norm ? i - K * K : i / K, q = norm ? p : i % K;
      if (i >= items || p > q) continue;
      for (int c = l; c < NDC; c += WG) {
        const real pq = r_mul(alpha[p * NDC + c], alpha[q * NDC + c]);
        v[j] = r_add(v[j], norm ? pq : r_mul(pq, inv_w[c]));
      }
    }
    sum3(v[0], v[1], v[2]);
    if (l == 0)
      for (int j = 0; j < 3 && i0 + j < items; ++j) {
        const int i = i0 + j;
        if (i >= K * K) work[N2 + i - K * K] = v[j];
        else if (i / K <= i % K) work[VV + i] = v[j];
      }
  }
  sync_work();
  if (l == 0) {
    for (int p = 0; p < K; ++p)
      for (int q = 0; q < p; ++q) work[VV + p * K + q] = work[VV + q * K + p];
    for (int k = 0; k < K; ++k) work[SH + k] = r_div(r_sub(frame[FR_RHS + 3 * nc + k], work[VOL + k]), r_f(float(pc.left)));
  }
  sync_work();

  real vol = r_zero(), share = r_zero(), ss = r_zero();
  for (int k = 0; k < K; ++k) {
    vol = r_add(vol, work[VOL + k]);
    share = r_add(share, work[SH + k]);
    for (int m = 0; m < K; ++m) ss = r_add(ss, work[VV + k * K + m]);  // t W^-1 t, t = the rows' sum
  }
  int status = 0;
  real detail = r_zero();
  for (int k = 0; k < K && status == 0; ++k) {
    const real g = work[VV + k * K + k];
    if (!(r_hi(g) > R_TINY) || !(r_hi(g) > scal(1e-24) * r_hi(work[N2 + k]) * r_hi(frame[FR_MAX_INVW]))) {
      status = 1;
      detail = r_f(float(k));
    }
  }
  if (status == 0) {
    for (int i = l; i < K * nc + nc; i += WG) {
      if (i < K * nc) {
        const int k = i / nc, s = i % nc, base = cons_i[CI_BASE + s];
        real g = r_zero();
        int o = s * KKK;
        for (int a = 0; a < KU; ++a)
          for (int b = 0; b < KV; ++b)
            for (int e = 0; e < KW; ++e, ++o) {
              const int c = tie(base + (a * NV + b) * NW + e);
              g = r_add(g, r_mul(r_mul(cons_d[o], inv_w[c]), alpha[k * NDC + c]));
            }
        work[GV + i] = g;
      } else {
        const int s = i - K * nc, base = cons_i[CI_BASE + s];
        real moved = r_zero();
        int o = s * KKK;
        for (int a = 0; a < KU; ++a)
          for (int b = 0; b < KV; ++b)
            for (int e = 0; e < KW; ++e, ++o) {
              const int c = tie(base + (a * NV + b) * NW + e);
              moved = r_add(moved, r_mul(cons_d[o], delta[ax * NDC + c]));
            }
        work[B + s] = r_sub(frame[FR_RHS + ax * nc + s], moved);
      }
    }
    sync_work();
    const int H = cons_i[CI_H];
    for (int i = l; i < K * nc; i += WG) {
      const int k = i / nc, p = i % nc;
      real y = r_zero();
      for (int q = 0; q < nc; ++q) y = r_add(y, r_mul(cons_d[H + p * nc + q], work[GV + k * nc + q]));
      work[Y + i] = y;
    }
    sync_work();
    for (int i = l; i < K * K; i += WG) {
      const int k = i / K, m = i % K;
      real v = work[VV + i];
      for (int s = 0; s < nc; ++s) v = r_sub(v, r_mul(work[GV + k * nc + s], work[Y + m * nc + s]));
      work[S + i] = v;
    }
    sync_work();
    if (l == 0) {
      // LDL^T of S (its lower triangle); pivot j of the unit-diagonal S is d_j / G_vv,jj.
      const real hi = r_add(frame[FR_HI], r_f(float(K)));
      int st3 = 0;
      for (int j = 0; j < K && st3 == 0; ++j) {
        real d = work[S + j * K + j];
        for (int t = 0; t < j; ++t) d = r_sub(d, r_mul(r_mul(work[FAC + j * K + t], work[FAC + j * K + t]), work[FAC + t * K + t]));
        if (!(r_hi(d) > scal(1e-12) * r_hi(hi) * r_hi(work[VV + j * K + j]))) st3 = 1;
        work[FAC + j * K + j] = d;
        for (int i = j + 1; i < K && st3 == 0; ++i) {
          real x = work[S + i * K + j];
          for (int t = 0; t < j; ++t) x = r_sub(x, r_mul(r_mul(work[FAC + i * K + t], work[FAC + j * K + t]), work[FAC + t * K + t]));
          work[FAC + i * K + j] = r_div(x, d);
        }
      }
      s_status = st3;
    }
    barrier();
    sync_work();
    if (s_status != 0) status = 3;
    if (status == 0) {
      eliminate(SH, B, LV, LC, nc);
      // Residual of the whole system, then the same elimination on it.
      for (int i = l; i < K + nc; i += WG) {
        if (i < K) {
          real r = work[SH + i];
          for (int m = 0; m < K; ++m) r = r_sub(r, r_mul(work[VV + i * K + m], work[LV + m]));
          for (int s = 0; s < nc; ++s) r = r_sub(r, r_mul(work[GV + i * nc + s], work[LC + s]));
          work[RV + i] = r;
        } else {
          const int p = i - K;
          real r = work[B + p];
          for (int k = 0; k < K; ++k) r = r_sub(r, r_mul(work[GV + k * nc + p], work[LV + k]));
          for (int q = 0; q < nc; ++q) r = r_sub(r, r_mul(cons_d[G + p * nc + q], work[LC + q]));
          work[RC + p] = r;
        }
      }
      sync_work();
      eliminate(RV, RC, DV, DC, nc);
      for (int i = l; i < K + nc; i += WG) {
        if (i < K) work[LV + i] = r_add(work[LV + i], work[DV + i]);
        else work[LC + i - K] = r_add(work[LC + i - K], work[DC + i - K]);
      }
      sync_work();
    }
  }

  // delta = W^-1 (sum_k lambda_k alpha_k + sum_s lambda_s B(u_s)).
  real mx = r_zero();
  const int ptr = cons_i[CI_PTR], idx = cons_i[CI_IDX];
  for (int c = l; c < NDC; c += WG) {
    real d = r_zero();
    const real iw = inv_w[c];
    if (status == 0 && r_hi(iw) > 0.0) {
      real s = r_zero();
      for (int k = 0; k < K; ++k) s = r_add(s, r_mul(work[LV + k], alpha[k * NDC + c]));
      for (int p = cons_i[ptr + c]; p < cons_i[ptr + c + 1]; ++p) {
        const int e = cons_i[idx + p];
        s = r_add(s, r_mul(work[LC + e / KKK], cons_d[e]));
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
    stats[st + 2] = ss;
    stats[st + 3] = s_a[0];
    stats[st + 4] = r_f(float(status));
    stats[st + 5] = detail;
    if (pc.step == 0)
      for (int k = 0; k < K; ++k) stats[ST_PART_BEFORE + k] = work[VOL + k];
  }
}

void main() {
  if (NPART > 1) {
    solve_parts();
    return;
  }
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
    if (pc.step == 0) stats[ST_PART_BEFORE] = vol;
  }
}
