#version 450
// The closed-form offsets of one axis step (one workgroup): minimise
// sum_c w_c delta_c^2 subject to R delta = b, where R holds the volume row alpha
// (b = the step's share of the missing volume) and one basis row per point
// constraint. delta = W^-1 R^T lambda with G lambda = b, G = R W^-1 R^T (m x m,
// m = 1 + constraints). The O(N) sums of G's first row are reduced here; the
// constraint block is constant and comes from the host. G is solved like the CPU
// backend does (solve.h): unit-diagonal scaling, Jacobi eigen-decomposition (which
// also gives the condition number for the error message), one refinement step.
// Failures are written as a status the host turns into the CPU's SolverError.
#include "common.glsl"
layout(local_size_x = 256) in;

shared double s_a[256];
shared double s_b[256];
shared double s_c[256];
shared double s_g0[32];
shared double A[32 * 32];
shared double Vec[32 * 32];

void main() {
  const uint l = gl_LocalInvocationID.x;
  const bool volrow = (pc.flags & 1) != 0;
  const int nc = par_i[PI_NC];
  const int nv = volrow ? 1 : 0;
  const int m = nv + nc;
  const int st = ST_STEP + pc.step * ST_STEP_STRIDE;
  const int lam = ST_LAMBDA + pc.step * ST_LAMBDA_STRIDE;

  double vol = 0.0, s2w = 0.0, s2 = 0.0;
  if (volrow) {
    for (uint i = l; i < uint(NTILE); i += 256) vol += tile_vol[i];
    for (uint c = l; c < uint(NCP); c += 256) {
      const double a = alpha[c];
      s2w += a * a * inv_w[c];
      s2 += a * a;
    }
  }
  s_a[l] = vol;
  s_b[l] = s2w;
  s_c[l] = s2;
  barrier();
  for (uint h = 128; h > 0; h >>= 1) {
    if (l < h) {
      s_a[l] += s_a[l + h];
      s_b[l] += s_b[l + h];
      s_c[l] += s_c[l + h];
    }
    barrier();
  }
  if (volrow && int(l) < nc) {
    // Row 0 against constraint l: sum over its K^3 support of alpha W^-1 r.
    const int s = int(l);
    const int base = (par_i[PI_CONS + 3 * s] * NV + par_i[PI_CONS + 3 * s + 1]) * NW + par_i[PI_CONS + 3 * s + 2];
    double g = 0.0;
    for (int i = 0; i < KU; ++i)
      for (int j = 0; j < KV; ++j)
        for (int k = 0; k < KW; ++k) {
          const int c = base + (i * NV + j) * NW + k;
          g += alpha[c] * inv_w[c] * constraint_row(s, c);
        }
    s_g0[s] = g;
  }
  barrier();
  if (l != 0) return;

  vol = s_a[0];
  s2w = s_b[0];
  s2 = s_c[0];
  double b[32], d[32], ev[32], lambda[32], r[32];
  double share = 0.0;
  if (volrow) share = (par_d[PD_TARGET] - vol) / double(pc.left);
  stats[st] = vol;
  stats[st + 1] = share;
  stats[st + 2] = volrow ? s2w : 0.0;
  // G into A (kept in Vec's place until scaled).
  for (int p = 0; p < m; ++p)
    for (int q = 0; q < m; ++q) {
      double g;
      if (volrow && p == 0 && q == 0) g = s2w;
      else if (volrow && p == 0) g = s_g0[q - 1];
      else if (volrow && q == 0) g = s_g0[p - 1];
      else g = par_d[PD_GCC + (p - nv) * nc + (q - nv)];
      A[p * 32 + q] = g;
    }
  if (volrow) b[0] = share;
  for (int s = 0; s < nc; ++s) b[nv + s] = par_d[PD_CONS + s * PD_CONS_STRIDE + 3 * KMAX + pc.axis];

  int status = 0;
  double detail = 0.0;
  const double max_iw = par_d[PD_MAX_INVW];
  for (int p = 0; p < m && status == 0; ++p) {
    const double scale = (volrow && p == 0) ? s2 : par_d[PD_CONS + (p - nv) * PD_CONS_STRIDE + 3 * KMAX + 3];
    const double gpp = A[p * 32 + p];
    if (!(gpp > 1e-300) || !(gpp > 1e-24 * scale * max_iw)) {
      status = (volrow && p == 0) ? 1 : 2;
      detail = double(p - nv);
    }
  }
  for (int p = 0; p < 32; ++p) lambda[p] = 0.0;
  if (status == 0) {
    // Gn = D G D with D = diag(G)^-1/2, eigen-decomposed in place: A -> diag(ev), Vec.
    for (int p = 0; p < m; ++p) d[p] = 1.0 / sqrt(A[p * 32 + p]);
    for (int p = 0; p < m; ++p)
      for (int q = 0; q < m; ++q) {
        Vec[p * 32 + q] = p == q ? 1.0 : 0.0;
      }
    double Gs[32 * 32];  // unscaled G, for the refinement residual
    for (int p = 0; p < m; ++p)
      for (int q = 0; q < m; ++q) {
        Gs[p * 32 + q] = A[p * 32 + q];
        A[p * 32 + q] *= d[p] * d[q];
      }
    for (int sweep = 0; sweep < 64; ++sweep) {
      double off = 0.0;
      for (int p = 0; p < m; ++p)
        for (int q = p + 1; q < m; ++q) off += A[p * 32 + q] * A[p * 32 + q];
      if (!(off > 1e-60)) break;
      for (int p = 0; p < m; ++p)
        for (int q = p + 1; q < m; ++q) {
          const double apq = A[p * 32 + q];
          if (abs(apq) < 1e-300) continue;
          const double theta = (A[q * 32 + q] - A[p * 32 + p]) / (2.0 * apq);
          const double t = (theta >= 0.0 ? 1.0 : -1.0) / (abs(theta) + sqrt(theta * theta + 1.0));
          const double c = 1.0 / sqrt(t * t + 1.0), s = t * c;
          for (int k = 0; k < m; ++k) {
            const double akp = A[k * 32 + p], akq = A[k * 32 + q];
            A[k * 32 + p] = c * akp - s * akq;
            A[k * 32 + q] = s * akp + c * akq;
          }
          for (int k = 0; k < m; ++k) {
            const double apk = A[p * 32 + k], aqk = A[q * 32 + k];
            A[p * 32 + k] = c * apk - s * aqk;
            A[q * 32 + k] = s * apk + c * aqk;
          }
          for (int k = 0; k < m; ++k) {
            const double vkp = Vec[k * 32 + p], vkq = Vec[k * 32 + q];
            Vec[k * 32 + p] = c * vkp - s * vkq;
            Vec[k * 32 + q] = s * vkp + c * vkq;
          }
        }
    }
    double lo = 1e300, hi = -1e300;
    for (int p = 0; p < m; ++p) {
      ev[p] = A[p * 32 + p];
      lo = min(lo, ev[p]);
      hi = max(hi, ev[p]);
    }
    if (!(lo > 1e-12 * hi)) {
      status = 3;
      detail = lo > 0.0 ? hi / lo : 1.0 / 0.0;
    } else {
      // lambda = D V diag(1/ev) V^T D rhs, twice: the second on the residual.
      for (int p = 0; p < m; ++p) r[p] = b[p];
      for (int pass = 0; pass < 2; ++pass) {
        double y[32];
        for (int q = 0; q < m; ++q) {
          double s = 0.0;
          for (int p = 0; p < m; ++p) s += Vec[p * 32 + q] * d[p] * r[p];
          y[q] = s / ev[q];
        }
        for (int p = 0; p < m; ++p) {
          double s = 0.0;
          for (int q = 0; q < m; ++q) s += Vec[p * 32 + q] * y[q];
          lambda[p] += d[p] * s;
        }
        for (int p = 0; p < m; ++p) {
          double s = b[p];
          for (int q = 0; q < m; ++q) s -= Gs[p * 32 + q] * lambda[q];
          r[p] = s;
        }
      }
    }
    if (status != 0)
      for (int p = 0; p < 32; ++p) lambda[p] = 0.0;
  }
  for (int p = 0; p < 32; ++p) stats[lam + p] = lambda[p];
  stats[st + 4] = double(status);
  stats[st + 5] = detail;
}
