// `real`: the type of every sum of the vpffd shaders, in one of two builds.
//
// Default: float64 (needs shaderFloat64). With VPFFD_FLOAT_FLOAT: a float-float
// pair vec2(hi, lo) whose value is hi + lo, |lo| <= ulp(hi) / 2: about 48
// significant bits from float32 arithmetic alone, for devices without float64
// (and an option for those whose float64 runs at 1/32 or 1/64 of the float32 rate:
// each operation costs ~10-20 float32 ones, so it may or may not win there). Both
// occupy 8 bytes, so the buffers have the same layout; the host converts at upload
// and read-back (vulkan_deformer.cpp, put_reals/get_real).
//
// The float-float operations are the classic error-free transformations: Knuth's
// two-sum and Dekker's product with Veltkamp's split. They need every float32
// addition and multiplication rounded as written, which Vulkan guarantees for add,
// sub and mul (correctly rounded) once the compiler may not fuse or reassociate
// them: hence `precise` on every intermediate. fma() is not used: SPIR-V does not
// promise that it is fused. Range: float32's exponents (about 1e-38 .. 3e38), so
// thresholds that were 1e-300 in float64 are 1e-37 here. Division: float-float
// quotient refined twice, to the format's precision.
//
// The shaders write arithmetic with the r_ functions in both builds, so one source
// serves both, and the float64 build computes exactly what plain double
// expressions would (each r_ function is one operation there).

#ifdef VPFFD_FLOAT_FLOAT

#define real vec2
#define scal float              // the type of thresholds and of r_hi()
#define R_TINY 1e-37

// s + e = a + b exactly.
vec2 ff_two_sum(float a, float b) {
  precise float s = a + b;
  precise float v = s - a;
  precise float e = (a - (s - v)) + (b - v);
  return vec2(s, e);
}

// s + e = a + b exactly, when |a| >= |b| (or a == 0).
vec2 ff_fast_two_sum(float a, float b) {
  precise float s = a + b;
  precise float e = b - (s - a);
  return vec2(s, e);
}

// a = hi + lo with 12 significant bits each (Veltkamp, factor 2^12 + 1).
vec2 ff_split(float a) {
  precise float t = 4097.0 * a;
  precise float hi = t - (t - a);
  precise float lo = a - hi;
  return vec2(hi, lo);
}

// p + e = a * b exactly (Dekker).
vec2 ff_two_prod(float a, float b) {
  precise float p = a * b;
  const vec2 x = ff_split(a), y = ff_split(b);
  precise float e = ((x.x * y.x - p) + x.x * y.y + x.y * y.x) + x.y * y.y;
  return vec2(p, e);
}

real r_f(float a) { return vec2(a, 0.0); }
real r_zero() { return vec2(0.0); }
float r_to_float(real a) { return a.x; }  // hi is a + lo rounded to nearest
scal r_hi(real a) { return a.x; }
real r_neg(real a) { return -a; }

real r_add(real a, real b) {
  const vec2 s = ff_two_sum(a.x, b.x);
  const vec2 t = ff_two_sum(a.y, b.y);
  precise float e = s.y + t.x;
  const vec2 u = ff_fast_two_sum(s.x, e);
  precise float e2 = u.y + t.y;
  return ff_fast_two_sum(u.x, e2);
}
real r_sub(real a, real b) { return r_add(a, -b); }

real r_mul(real a, real b) {
  const vec2 p = ff_two_prod(a.x, b.x);
  precise float e = p.y + (a.x * b.y + a.y * b.x);
  return ff_fast_two_sum(p.x, e);
}
real r_mulf(real a, float b) {
  const vec2 p = ff_two_prod(a.x, b);
  precise float e = p.y + a.y * b;
  return ff_fast_two_sum(p.x, e);
}
// The exact product of two floats.
real r_prod(float a, float b) { return ff_two_prod(a, b); }

real r_div(real a, real b) {
  // Long division: each quotient digit removes ~24 bits of the remainder, and the
  // remainders are computed exactly enough that float division's 2.5 ulp do not matter.
  const float q1 = a.x / b.x;
  real r = r_sub(a, r_mulf(b, q1));
  const float q2 = r.x / b.x;
  r = r_sub(r, r_mulf(b, q2));
  const float q3 = r.x / b.x;
  return r_add(ff_fast_two_sum(q1, q2), vec2(q3, 0.0));
}

real r_abs(real a) { return a.x < 0.0 || (a.x == 0.0 && a.y < 0.0) ? -a : a; }
// The largest integer <= hi + lo, exactly: if hi is not an integer, |lo| <= ulp(hi) / 2
// leaves hi + lo strictly between floor(hi) and floor(hi) + 1.
real r_floor(real a) {
  const float f = floor(a.x);
  return f != a.x ? vec2(f, 0.0) : ff_fast_two_sum(f, floor(a.y));
}
bool r_less(real a, real b) { return a.x < b.x || (a.x == b.x && a.y < b.y); }
real r_max(real a, real b) { return r_less(a, b) ? b : a; }

// The product of three basis values: coef and gather must form it identically (the
// volume change of a step is alpha . delta only if both use the same B). float32
// here: it multiplies reals, so its rounding moves a vertex by ~1e-7 of its offset.
#define basis_t float
float b3(float a, float b, float c) {
  precise float p = (a * b) * c;
  return p;
}
real r_mulb(real x, basis_t b) { return r_mulf(x, b); }

#else  // float64

#define real double
#define scal double
#define R_TINY 1e-300

real r_f(float a) { return double(a); }
real r_zero() { return 0.0; }
float r_to_float(real a) { return float(a); }
scal r_hi(real a) { return a; }
real r_neg(real a) { return -a; }
real r_add(real a, real b) { return a + b; }
real r_sub(real a, real b) { return a - b; }
real r_mul(real a, real b) { return a * b; }
real r_mulf(real a, float b) { return a * double(b); }
real r_prod(float a, float b) { return double(a) * double(b); }  // exact: 48 < 53 bits
real r_div(real a, real b) { return a / b; }
real r_abs(real a) { return abs(a); }
real r_floor(real a) { return floor(a); }
bool r_less(real a, real b) { return a < b; }
real r_max(real a, real b) { return max(a, b); }

#define basis_t double
basis_t b3(float a, float b, float c) { return (double(a) * double(b)) * double(c); }
real r_mulb(real x, basis_t b) { return x * b; }

#endif
