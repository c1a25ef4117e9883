/* Small vector and scalar math, written with + - * /, sqrt, fabs, floor and compares
 * only: those are exactly rounded on both sides, where built-ins such as dot,
 * normalize or pow are implementation-defined (docs/architecture.md, "Bitwise parity"). */

/* |x| and the correctly rounded square root. Under clang's OpenCL C (PoCL) they are
 * clang's built-ins, which become LLVM intrinsics: OpenCL C's fabs and sqrt are calls
 * into the device's library, which PoCL links only after the front end has optimized
 * the program, and OpenCL C marks every call convergent (it may hold a barrier). LLVM's
 * loop vectorizer does not if-convert a loop around a convergent call, so PoCL's front
 * end left every ray-per-lane loop that called fabs scalar, the packet's triangle test
 * among them, and said so in the build log (its later compile of the work-group
 * function recovered most of it: docs/performance.md, "Other measured changes"). Same
 * values: both are exact IEEE operations on either side. TR_LIBRARY_MATH keeps OpenCL
 * C's (Oclgrind 21.10 knows neither llvm.fabs nor llvm.sqrt: run_oclgrind.cmake). */
#if defined(TR_DEVICE) && defined(__clang__) && !defined(TR_LIBRARY_MATH)
#ifdef TR_DOUBLE
#define TR_BUILTIN_FABS __builtin_fabs
#define TR_BUILTIN_SQRT __builtin_sqrt
#else
#define TR_BUILTIN_FABS __builtin_fabsf
#define TR_BUILTIN_SQRT __builtin_sqrtf
#endif
#else
#define TR_BUILTIN_FABS fabs
#define TR_BUILTIN_SQRT sqrt
#endif
TR_FN_INLINE real tr_fabs(real x) {
  return TR_BUILTIN_FABS(x);
}
TR_FN_INLINE real tr_sqrt(real x) {
  return TR_BUILTIN_SQRT(x);
}

TR_FN real tr_min(real a, real b) {
  return a < b ? a : b;
}
TR_FN real tr_max(real a, real b) {
  return a > b ? a : b;
}
TR_FN real tr_clamp01(real a) {
  return a < TR_R(0.0) ? TR_R(0.0) : (a > TR_R(1.0) ? TR_R(1.0) : a);
}

TR_FN real tr_dot(vec3 a, vec3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}

/* a - b, built from the components' differences: the values of vec3 subtraction, but
 * no float3 arithmetic, which LLVM's loop vectorizer does not widen; a vector only
 * built and taken apart again folds into scalars. For the primitive tests, whose
 * ray-per-lane loops (bvh_packet.h) PoCL then vectorizes too. */
TR_FN_INLINE vec3 tr_sub3(vec3 a, vec3 b) {
  return TR_VEC3(a.x - b.x, a.y - b.y, a.z - b.z);
}
/* a + b and v s, in components for the same reason: shading's per-hit loops
 * (trace.h) vectorize a hit per SIMD lane over them. */
TR_FN_INLINE vec3 tr_add3(vec3 a, vec3 b) {
  return TR_VEC3(a.x + b.x, a.y + b.y, a.z + b.z);
}
TR_FN_INLINE vec3 tr_scale3(vec3 v, real s) {
  return TR_VEC3(v.x * s, v.y * s, v.z * s);
}

/* Lane i of v, and lane i of v set to a. */
TR_FN_INLINE vec3 tr_lane3(const TrVec3Lanes* v, int i) {
  return TR_VEC3(v->x[i], v->y[i], v->z[i]);
}
TR_FN_INLINE void tr_set_lane3(TrVec3Lanes* v, int i, vec3 a) {
  v->x[i] = a.x;
  v->y[i] = a.y;
  v->z[i] = a.z;
}

/* Componentwise minimum and maximum. */
TR_FN vec3 tr_min3(vec3 a, vec3 b) {
  return TR_VEC3(tr_min(a.x, b.x), tr_min(a.y, b.y), tr_min(a.z, b.z));
}
TR_FN vec3 tr_max3(vec3 a, vec3 b) {
  return TR_VEC3(tr_max(a.x, b.x), tr_max(a.y, b.y), tr_max(a.z, b.z));
}

TR_FN vec3 tr_cross(vec3 a, vec3 b) {
  return TR_VEC3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}

TR_FN real tr_length(vec3 v) {
  return tr_sqrt(tr_dot(v, v));
}

TR_FN vec3 tr_normalize(vec3 v) {
  return tr_scale3(v, TR_R(1.0) / tr_sqrt(tr_dot(v, v)));
}

TR_FN vec3 tr_abs3(vec3 v) {
  return TR_VEC3(tr_fabs(v.x), tr_fabs(v.y), tr_fabs(v.z));
}

TR_FN real tr_max_component(vec3 v) {
  return tr_max(v.x, tr_max(v.y, v.z));
}

/* Component i (0, 1, 2) of v; OpenCL vectors cannot be indexed at run time. */
TR_FN_INLINE real tr_component(vec3 v, int i) {
  return i == 0 ? v.x : (i == 1 ? v.y : v.z);
}
/* The greatest magnitude of three: tr_max_component(tr_abs3(v)) for v = (x, y, z), in
 * scalars (no float3 arithmetic, which LLVM's loop vectorizer does not widen). */
TR_FN_INLINE real tr_max_abs(real x, real y, real z) {
  return tr_max(tr_fabs(x), tr_max(tr_fabs(y), tr_fabs(z)));
}

/* Unit roundoff of real: 2^-24 for float, 2^-53 for double. */
TR_FN real tr_unit_roundoff(void) {
  return sizeof(real) == 4 ? TR_R(1.0) / TR_R(16777216.0) : TR_R(1.0) / TR_R(9007199254740992.0);
}

/* gamma(n) = n u / (1 - n u): the bound on the relative error of n successive rounded
 * operations (Higham, Accuracy and Stability of Numerical Algorithms, 3.1; pbrt-v4's
 * gamma()). */
TR_FN real tr_gamma(int n) {
  real nu = (real)n * tr_unit_roundoff();
  return nu / (TR_R(1.0) - nu);
}

/* Error-free transformations, exact with round-to-nearest and no contraction (the
 * parity rules guarantee both), from + - * only:
 *  - TwoSum (Knuth, TAOCP vol. 2, 4.2.2): a + b = s + e exactly;
 *  - Veltkamp's split and Dekker's product ("A floating-point technique for extending
 *    the available precision", Numer. Math. 18, 1971): a * a = p + e exactly, valid
 *    while splitter * a does not overflow (|a| < 2^115 in float, 2^995 in double).
 * Ogita, Rump and Oishi's Sum2 ("Accurate sum and dot product", SISC 26(6), 2005)
 * combines them into sums as accurate as if computed in twice the precision. */
TR_FN real tr_two_sum(real a, real b, real* err) {
  real s = a + b;
  real bb = s - a;
  *err = (a - (s - bb)) + (b - bb);
  return s;
}

TR_FN real tr_two_square(real a, real* err) {
  real splitter = sizeof(real) == 4 ? TR_R(4097.0) : TR_R(134217729.0); /* 2^12+1, 2^27+1 */
  real c = splitter * a;
  real hi = c - (c - a);
  real lo = a - hi;
  real p = a * a;
  *err = ((hi * hi - p) + TR_R(2.0) * hi * lo) + lo * lo;
  return p;
}

/* result[l] times base[l]^bits for l < n, by squaring from the lowest bit: for each set
 * bit the result is multiplied by the base, then the base squared while bits remain.
 * tr_pow_unit's integer steps, for one value or for a block's hits at once
 * (tr_specular_powers), where the loop over l is the inner one and g++ vectorizes it.
 * base[] is left squared. */
TR_FN void tr_pow_bits(real* result, real* base, int n, int bits) {
  for (; bits > 0; bits = bits >> 1) {
    if ((bits & 1) != 0)
      for (int l = 0; l < n; ++l) result[l] = result[l] * base[l];
    if (bits > 1)
      for (int l = 0; l < n; ++l) base[l] = base[l] * base[l];
  }
}

/* x^p for x in [0, 1] and any real p >= 0, from exactly rounded operations only, so
 * both sides agree bit for bit (the built-in pow differs by 1-2 ulp between glibc and
 * PoCL's SLEEF). The integer part of p goes by repeated squaring; the fractional part
 * 0.b1 b2 b3... by its binary digits, x^(2^-k) being k square roots of x. Each step
 * rounds once; like any multiplication chain for x^n its relative error is bounded by
 * about (p + digits) ulp (in practice far less: 8e-5 relative at p = 1e4 in float),
 * invisible in a highlight and the same on both sides. */
TR_FN real tr_pow_unit(real x, real p) {
  real result = TR_R(1.0);
  real whole = floor(p);
  real frac = p - whole; /* exact */
  real base = x;
  /* Bit by bit from the lowest: as reals while the exponent has bits above 2^24, then
   * as an int, which holds it exactly. The same steps either way; the int's halving
   * is one shift, where PoCL compiles floor() to a dozen instructions. */
  while (whole >= TR_R(16777216.0) && result > TR_R(0.0)) {
    real halved = floor(whole * TR_R(0.5));
    if (whole - halved * TR_R(2.0) > TR_R(0.0)) result = result * base;
    whole = halved;
    base = base * base;
  }
  /* A zero result stays zero (the base is in [0, 1]); the loop above may have left it
   * so with a whole part an int cannot hold. */
  if (result > TR_R(0.0)) tr_pow_bits(&result, &base, 1, (int)whole);
  int digits = sizeof(real) == 4 ? 24 : 53;
  real root = x;
  for (int k = 0; k < digits && frac > TR_R(0.0); ++k) {
    frac = frac * TR_R(2.0); /* exact: shifts the next binary digit in front */
    root = tr_sqrt(root);
    if (frac >= TR_R(1.0)) {
      result = result * root;
      frac = frac - TR_R(1.0);
    }
  }
  return result;
}

/* Is a feature compiled in (TR_HAS) and switched on for this frame? */
TR_FN int tr_use(const TrSceneRef* s, unsigned bit) {
#ifdef TR_EXACT_FEATURES
  /* The program was built for this frame's mask (OpenCL, opencl::build_options): its
   * bits are the frame's, and what a clear bit guards is left out of the code. */
  (void)s;
  return TR_HAS(bit);
#else
  return TR_HAS(bit) && (((unsigned)s->params->features & bit) != 0u);
#endif
}
