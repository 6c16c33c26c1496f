// B-spline basis values and first derivatives of one axis, evaluated in reals
// (real.glsl) and rounded once to float32: shared by normals.comp and multires.comp.
//
// The including shader defines BASIS_TAB as the name of its real buffer that holds
// the three axes' per-span power forms (the core's layout: coefficient of tau^q of
// function r of span s at off + s K^2 + q K + r) before including this file.
//
// Why reals: a float32 power form errs by up to ~(2d + 1) sum_q |c_q| u, which for
// clamped cubic spans is hundreds of u; evaluated in reals from real coefficients and
// rounded once, a value or derivative errs by u of itself plus the float32 parameter's
// rounding (tests/python/gpu_bounds.py, _axis_errors). 3 K^2 real operations per point.

#ifndef BASIS_TAB
#error "define BASIS_TAB (the real buffer of power forms) before including basis_reals.glsl"
#endif

// Values b and derivatives db (d/dy: d/dtau times the span's scale `s`) of one axis's
// K functions at local parameter t, on the span whose power form starts at
// off + first K^2. Entries K..KMAX-1 are zero.
void eval_axis_d(int off, int K, int first, float t, real s, out float b[KMAX], out float db[KMAX]) {
  const int base = off + first * K * K;
  const real rt = r_f(t);
  for (int r = 0; r < KMAX; ++r) {
    if (r >= K) {
      b[r] = 0.0;
      db[r] = 0.0;
      continue;
    }
    real v = BASIS_TAB[base + (K - 1) * K + r], dv = r_zero();
    for (int q = K - 2; q >= 0; --q) {
      dv = r_add(r_mul(dv, rt), v);
      v = r_add(r_mul(v, rt), BASIS_TAB[base + q * K + r]);
    }
    b[r] = r_to_float(v);
    db[r] = r_to_float(r_mul(dv, s));
  }
}
