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
#include "common.glsl"
layout(local_size_x = 256) in;
const int WG = 256;

shared double s_a[WG];
shared double s_b[WG];
shared double s_c[WG];

// Workgroup sums of three values in a fixed tree order; every invocation gets them.
void sum3(inout double a, inout double b, inout double c) {
  const uint l = gl_LocalInvocationID.x;
  s_a[l] = a;
  s_b[l] = b;
  s_c[l] = c;
  barrier();
  for (uint h = WG / 2; h > 0; h >>= 1) {
    if (l < h) {
      s_a[l] += s_a[l + h];
      s_b[l] += s_b[l + h];
      s_c[l] += s_c[l + h];
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

  double vol = 0.0, g00 = 0.0, s2 = 0.0;
  for (int i = l; i < NTILE; i += WG) vol += tile_vol[i];
  for (int c = l; c < NCP; c += WG) {
    const double a = alpha[c];
    g00 += a * a * inv_w[c];
    s2 += a * a;
  }
  sum3(vol, g00, s2);
  const double share = (frame[FR_TARGET] - vol) / double(pc.left);

  // Every invocation derives status from the same sums: the branches below are uniform.
  int status = 0;
  double detail = 0.0, lam0 = 0.0;
  // A zero row means nothing free can move the volume; relative to the unweighted norm.
  if (!(g00 > 1e-300) || !(g00 > 1e-24 * s2 * frame[FR_MAX_INVW])) status = 1;
  if (status == 0) {
    for (int s = l; s < nc; s += WG) {
      const int base = cons_i[CI_BASE + s];
      double g = 0.0, moved = 0.0;
      int o = s * KKK;
      for (int i = 0; i < KU; ++i)
        for (int j = 0; j < KV; ++j)
          for (int k = 0; k < KW; ++k, ++o) {
            const int c = base + (i * NV + j) * NW + k;
            const double r = cons_d[o];
            g += r * inv_w[c] * alpha[c];
            moved += r * delta[ax * NCP + c];
          }
      work[W_G + s] = g;
      work[W_B + s] = frame[FR_RHS + ax * nc + s] - moved;
    }
    sync_work();
    for (int p = l; p < nc; p += WG) {
      double y = 0.0, z = 0.0;
      for (int q = 0; q < nc; ++q) {
        const double h = cons_d[H + p * nc + q];
        y += h * work[W_G + q];
        z += h * work[W_B + q];
      }
      work[W_Y + p] = y;
      work[W_Z + p] = z;
    }
    sync_work();
    double gy = 0.0, gz = 0.0, unused = 0.0;
    for (int s = l; s < nc; s += WG) {
      gy += work[W_G + s] * work[W_Y + s];
      gz += work[W_G + s] * work[W_Z + s];
    }
    sum3(gy, gz, unused);
    const double schur = g00 - gy;
    // schur / g00 is the Schur complement of the unit-diagonal G, an upper bound of its
    // smallest eigenvalue: the CPU's test lo > 1e-12 hi fails whenever this one does.
    const double hi = frame[FR_HI];
    if (!(schur > 1e-12 * hi * g00)) {
      status = 3;
      detail = schur > 0.0 ? hi * g00 / schur : 1.0 / 0.0;
    } else {
      lam0 = (share - gz) / schur;
      for (int p = l; p < nc; p += WG) work[W_L + p] = work[W_Z + p] - work[W_Y + p] * lam0;
      sync_work();
      // Residual of G lambda = b, then the same elimination on it.
      double gl = 0.0, u0 = 0.0, u1 = 0.0;
      for (int p = l; p < nc; p += WG) {
        double r = work[W_B + p] - work[W_G + p] * lam0;
        for (int q = 0; q < nc; ++q) r -= cons_d[G + p * nc + q] * work[W_L + q];
        work[W_R + p] = r;
        gl += work[W_G + p] * work[W_L + p];
      }
      sum3(gl, u0, u1);
      const double r0 = share - g00 * lam0 - gl;
      sync_work();
      for (int p = l; p < nc; p += WG) {
        double z = 0.0;
        for (int q = 0; q < nc; ++q) z += cons_d[H + p * nc + q] * work[W_R + q];
        work[W_Z + p] = z;
      }
      sync_work();
      double gz2 = 0.0;
      for (int s = l; s < nc; s += WG) gz2 += work[W_G + s] * work[W_Z + s];
      sum3(gz2, u0, u1);
      const double d0 = (r0 - gz2) / schur;
      lam0 += d0;
      for (int p = l; p < nc; p += WG) work[W_L + p] += work[W_Z + p] - work[W_Y + p] * d0;
      sync_work();
    }
  }

  // delta = W^-1 (lambda_0 alpha + sum_s lambda_s B(u_s)), per control point through
  // its list of constraint entries (O(nc K^3) in all, not O(nc N)).
  double mx = 0.0;
  const int ptr = cons_i[CI_PTR], idx = cons_i[CI_IDX];
  for (int c = l; c < NCP; c += WG) {
    double d = 0.0;
    const double iw = inv_w[c];
    if (status == 0 && iw > 0.0) {
      double s = lam0 * alpha[c];
      for (int p = cons_i[ptr + c]; p < cons_i[ptr + c + 1]; ++p) {
        const int e = cons_i[idx + p];
        s += work[W_L + e / KKK] * cons_d[e];
      }
      d = iw * s;
    }
    delta[3 * NCP + c] = d;
    delta[ax * NCP + c] += d;
    mx = max(mx, abs(d));
  }
  s_a[l] = mx;
  barrier();
  for (int h = WG / 2; h > 0; h >>= 1) {
    if (l < h) s_a[l] = max(s_a[l], s_a[l + h]);
    barrier();
  }
  if (l == 0) {
    stats[st] = vol;
    stats[st + 1] = share;
    stats[st + 2] = g00;
    stats[st + 3] = s_a[0];
    stats[st + 4] = double(status);
    stats[st + 5] = detail;
  }
}
