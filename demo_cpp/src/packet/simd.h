// Lanes of rays for the packet engine: one small float/int/mask vocabulary with three
// implementations, chosen by RT_SIMD_LEVEL before this header is included (0: one lane,
// plain C++; 1: AVX2, 8 lanes; 2: AVX-512, 16 lanes). Each kernel translation unit includes
// it inside its own namespace, so the three never share a symbol (the linker must not pick an
// AVX-512 copy of an inline function for a CPU without it).
//
// Every operation is the single IEEE operation the scalar tracer performs (no fused
// multiply-add, no approximations), so a lane computes bit for bit what the scalar code does.
// Not a general SIMD library: only what the kernels use.
#ifndef RT_SIMD_LEVEL
#error "define RT_SIMD_LEVEL (0, 1 or 2) before including packet/simd.h"
#endif

// The root slips of student_slips.h a robust test can carry: negative_root_hit takes t0 when
// it lies at or behind the origin, near_root_only misses the sphere there (kernels.inc).
constexpr int kRootPlain = 0, kRootNegative = 1, kRootNearOnly = 2, kRootFar = 3;

#if RT_SIMD_LEVEL == 0

constexpr int W = 1;
struct VF {
    float v;
};
struct VI {
    int v;
};
using VM = bool;

inline VF operator+(VF a, VF b) { return {a.v + b.v}; }
inline VF operator-(VF a, VF b) { return {a.v - b.v}; }
inline VF operator*(VF a, VF b) { return {a.v * b.v}; }
inline VF operator/(VF a, VF b) { return {a.v / b.v}; }
inline VF operator-(VF a) { return {-a.v}; }
inline VF vsqrt(VF a) { return {std::sqrt(a.v)}; }
inline VF vabs(VF a) { return {std::fabs(a.v)}; }
inline VF fset(float x) { return {x}; }
inline VF fload(const float* p) { return {*p}; }
inline void fstore(float* p, VF a) { *p = a.v; }
inline VF fgather(const float* base, VI i) { return {base[i.v]}; }
inline VF ftable(const float* base, VI i) { return {base[i.v]}; }
inline VI itable(const int* base, VI i) { return {base[i.v]}; }
inline VM lt(VF a, VF b) { return a.v < b.v; }
inline VM le(VF a, VF b) { return a.v <= b.v; }
inline VM eq(VF a, VF b) { return a.v == b.v; }
inline VM isnan_(VF a) { return a.v != a.v; }
inline VF sel(VM m, VF a, VF b) { return m ? a : b; }
inline VF vmax_raw(VF a, VF b) { return {a.v > b.v ? a.v : b.v}; }  // x86 maxps: b on NaN

inline VI iset(int x) { return {x}; }
inline VI iload(const int* p) { return {*p}; }
inline void istore(int* p, VI a) { *p = a.v; }
// Each lane's low byte (values 0..255), W bytes.
inline void bstore(unsigned char* p, VI a) { *p = static_cast<unsigned char>(a.v); }
inline VI igather(const int* base, VI i) { return {base[i.v]}; }
inline VI iota() { return {0}; }
inline VI iand(VI a, VI b) { return {a.v & b.v}; }
inline VM ieq(VI a, VI b) { return a.v == b.v; }
inline VM igt(VI a, VI b) { return a.v > b.v; }
inline VI isel(VM m, VI a, VI b) { return m ? a : b; }
inline VF itof(VI a) { return {static_cast<float>(a.v)}; }  // exact below 2^24
inline VI ftoi(VF a) { return {static_cast<int>(a.v)}; }    // truncated; |a| < 2^31
inline VI iadd(VI a, VI b) { return {a.v + b.v}; }

inline VM mand(VM a, VM b) { return a && b; }
inline VM mor(VM a, VM b) { return a || b; }
inline VM mandnot(VM a, VM b) { return a && !b; }  // a and not b
inline VM mnot(VM a) { return !a; }
inline VM mall(bool b) { return b; }
inline bool any(VM m) { return m; }
inline bool all(VM m) { return m; }
inline unsigned bits(VM m) { return m ? 1u : 0u; }

// The lanes of m, packed, at dst (which may be written up to W entries on).
inline void compress_store(float* dst, VM m, VF v) {
    if (m) *dst = v.v;
}
inline void compress_store(int* dst, VM m, VI v) {
    if (m) *dst = v.v;
}
// dst[lane] = base + (set lanes of m below lane), for each set lane.
inline void rank_store(int* dst, VM m, int base) {
    if (m) *dst = base;
}
// The lanes of m take p[0], p[1], ... in order (the inverse of compress_store); others 0.
inline VF expand_load(const float* p, VM m) { return {m ? *p : 0.0f}; }
// The same, the other lanes keeping `src`.
inline VF expand_merge(VF src, VM m, const float* p) { return m ? VF{*p} : src; }
// The mask whose bits() are b.
inline VM from_bits(unsigned b) { return b != 0; }

// The robust test of intersect_robust in double, per lane: the first root in (0, inf) as a
// float, +inf where there is none; with a root slip (kRootNegative, kRootNearOnly) as
// intersect_robust_with_root_slip where t0 <= 0.
inline VF robust_candidate(VF ox_, VF oy_, VF oz_, VF dx_, VF dy_, VF dz_, float cx, float cy,
                           float cz, float radius, int slip) {
    const double ox = double(ox_.v) - cx, oy = double(oy_.v) - cy, oz = double(oz_.v) - cz;
    const double dx = dx_.v, dy = dy_.v, dz = dz_.v;
    const double b = ox * dx + oy * dy + oz * dz;
    const double px = ox - dx * b, py = oy - dy * b, pz = oz - dz * b;
    const double r2 = double(radius) * radius;
    const double disc = r2 - (px * px + py * py + pz * pz);
    if (disc < 0) return {std::numeric_limits<float>::infinity()};
    const double c = ox * ox + oy * oy + oz * oz - r2;
    const double q = -b - std::copysign(std::sqrt(disc), b);
    double t0 = (q != 0.0) ? c / q : 0.0;
    double t1 = q;
    if (t0 > t1) {
        const double s = t0;
        t0 = t1;
        t1 = s;
    }
    const float f0 = float(t0), f1 = float(t1);
    if (slip == kRootFar) return {f1 > 0 ? f1 : std::numeric_limits<float>::infinity()};
    if (slip != kRootPlain && f0 <= 0)
        return {slip == kRootNegative ? f0 : std::numeric_limits<float>::infinity()};
    return {f0 > 0 ? f0 : (f1 > 0 ? f1 : std::numeric_limits<float>::infinity())};
}

#elif RT_SIMD_LEVEL == 1

constexpr int W = 8;
struct VF {
    __m256 v;
};
struct VI {
    __m256i v;
};
struct VM {
    __m256 v;
};

inline VF operator+(VF a, VF b) { return {_mm256_add_ps(a.v, b.v)}; }
inline VF operator-(VF a, VF b) { return {_mm256_sub_ps(a.v, b.v)}; }
inline VF operator*(VF a, VF b) { return {_mm256_mul_ps(a.v, b.v)}; }
inline VF operator/(VF a, VF b) { return {_mm256_div_ps(a.v, b.v)}; }
inline VF operator-(VF a) { return {_mm256_xor_ps(a.v, _mm256_set1_ps(-0.0f))}; }
inline VF vsqrt(VF a) { return {_mm256_sqrt_ps(a.v)}; }
inline VF vabs(VF a) { return {_mm256_andnot_ps(_mm256_set1_ps(-0.0f), a.v)}; }
inline VF fset(float x) { return {_mm256_set1_ps(x)}; }
inline VF fload(const float* p) { return {_mm256_loadu_ps(p)}; }
inline void fstore(float* p, VF a) { _mm256_storeu_ps(p, a.v); }
inline VF fgather(const float* base, VI i) { return {_mm256_i32gather_ps(base, i.v, 4)}; }
// base[i] from a table of at most 8 entries (padded to 8) by one permute instead of a gather.
inline VF ftable(const float* base, VI i) {
    return {_mm256_permutevar8x32_ps(_mm256_loadu_ps(base), i.v)};
}
inline VI itable(const int* base, VI i) {
    return {_mm256_permutevar8x32_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(base)),
                                        i.v)};
}
inline VM lt(VF a, VF b) { return {_mm256_cmp_ps(a.v, b.v, _CMP_LT_OQ)}; }
inline VM le(VF a, VF b) { return {_mm256_cmp_ps(a.v, b.v, _CMP_LE_OQ)}; }
inline VM eq(VF a, VF b) { return {_mm256_cmp_ps(a.v, b.v, _CMP_EQ_OQ)}; }
inline VM isnan_(VF a) { return {_mm256_cmp_ps(a.v, a.v, _CMP_UNORD_Q)}; }
inline VF sel(VM m, VF a, VF b) { return {_mm256_blendv_ps(b.v, a.v, m.v)}; }
inline VF vmax_raw(VF a, VF b) { return {_mm256_max_ps(a.v, b.v)}; }

inline VI iset(int x) { return {_mm256_set1_epi32(x)}; }
inline VI iload(const int* p) { return {_mm256_loadu_si256(reinterpret_cast<const __m256i*>(p))}; }
inline void istore(int* p, VI a) { _mm256_storeu_si256(reinterpret_cast<__m256i*>(p), a.v); }
inline void bstore(unsigned char* p, VI a) {
    // Each 128-bit half's four low bytes to its front, then the halves' fronts side by side.
    const __m256i front = _mm256_shuffle_epi8(
        a.v, _mm256_setr_epi8(0, 4, 8, 12, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, 0, 4, 8,
                              12, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1));
    const __m128i both =
        _mm_unpacklo_epi32(_mm256_castsi256_si128(front), _mm256_extracti128_si256(front, 1));
    _mm_storel_epi64(reinterpret_cast<__m128i*>(p), both);
}
inline VI igather(const int* base, VI i) { return {_mm256_i32gather_epi32(base, i.v, 4)}; }
inline VI iota() { return {_mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7)}; }
inline VI iand(VI a, VI b) { return {_mm256_and_si256(a.v, b.v)}; }
inline VM ieq(VI a, VI b) { return {_mm256_castsi256_ps(_mm256_cmpeq_epi32(a.v, b.v))}; }
inline VM igt(VI a, VI b) { return {_mm256_castsi256_ps(_mm256_cmpgt_epi32(a.v, b.v))}; }
inline VI isel(VM m, VI a, VI b) {
    return {_mm256_castps_si256(
        _mm256_blendv_ps(_mm256_castsi256_ps(b.v), _mm256_castsi256_ps(a.v), m.v))};
}
inline VF itof(VI a) { return {_mm256_cvtepi32_ps(a.v)}; }
inline VI ftoi(VF a) { return {_mm256_cvttps_epi32(a.v)}; }
inline VI iadd(VI a, VI b) { return {_mm256_add_epi32(a.v, b.v)}; }

inline VM mand(VM a, VM b) { return {_mm256_and_ps(a.v, b.v)}; }
inline VM mor(VM a, VM b) { return {_mm256_or_ps(a.v, b.v)}; }
inline VM mandnot(VM a, VM b) { return {_mm256_andnot_ps(b.v, a.v)}; }
inline VM mnot(VM a) { return {_mm256_xor_ps(a.v, _mm256_castsi256_ps(_mm256_set1_epi32(-1)))}; }
inline VM mall(bool b) { return {_mm256_castsi256_ps(_mm256_set1_epi32(b ? -1 : 0))}; }
inline bool any(VM m) { return _mm256_movemask_ps(m.v) != 0; }
inline bool all(VM m) { return _mm256_movemask_ps(m.v) == 0xff; }
inline unsigned bits(VM m) { return static_cast<unsigned>(_mm256_movemask_ps(m.v)); }

// AVX2 has no compress: a permutation per 8-bit mask that moves the set lanes to the front.
struct CompressTable {
    alignas(32) int perm[256][8];    // compress: the set lanes to the front
    alignas(32) int expand[256][8];  // expand: set lane j takes element rank(j)
    constexpr CompressTable() : perm{}, expand{} {
        for (int m = 0; m < 256; ++m) {
            int k = 0;
            for (int lane = 0; lane < 8; ++lane)
                if (m >> lane & 1) {
                    expand[m][lane] = k;
                    perm[m][k++] = lane;
                }
            for (; k < 8; ++k) perm[m][k] = 0;
        }
    }
};
constexpr CompressTable kCompress{};
inline void compress_store(float* dst, VM m, VF v) {
    const __m256i perm =
        _mm256_load_si256(reinterpret_cast<const __m256i*>(kCompress.perm[bits(m)]));
    _mm256_storeu_ps(dst, _mm256_permutevar8x32_ps(v.v, perm));
}
inline void compress_store(int* dst, VM m, VI v) {
    const __m256i perm =
        _mm256_load_si256(reinterpret_cast<const __m256i*>(kCompress.perm[bits(m)]));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(dst), _mm256_permutevar8x32_epi32(v.v, perm));
}
inline void rank_store(int* dst, VM m, int base) {
    const __m256i rank =
        _mm256_load_si256(reinterpret_cast<const __m256i*>(kCompress.expand[bits(m)]));
    _mm256_maskstore_epi32(dst, _mm256_castps_si256(m.v),
                           _mm256_add_epi32(rank, _mm256_set1_epi32(base)));
}
inline VF expand_load(const float* p, VM m) {
    const __m256i perm =
        _mm256_load_si256(reinterpret_cast<const __m256i*>(kCompress.expand[bits(m)]));
    return {_mm256_and_ps(_mm256_permutevar8x32_ps(_mm256_loadu_ps(p), perm), m.v)};
}
inline VF expand_merge(VF src, VM m, const float* p) { return sel(m, expand_load(p, m), src); }
inline VM from_bits(unsigned b) {
    const __m256i lane = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    return {_mm256_castsi256_ps(
        _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(static_cast<int>(b)), lane), lane))};
}

// Four lanes of intersect_robust in double (see the scalar version above for the steps).
inline __m128 robust4(__m256d ox, __m256d oy, __m256d oz, __m256d dx, __m256d dy, __m256d dz,
                      double r2, int slip) {
    const __m256d sign = _mm256_set1_pd(-0.0), zero = _mm256_setzero_pd();
    const __m256d b = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(ox, dx), _mm256_mul_pd(oy, dy)),
                                    _mm256_mul_pd(oz, dz));
    const __m256d px = _mm256_sub_pd(ox, _mm256_mul_pd(dx, b));
    const __m256d py = _mm256_sub_pd(oy, _mm256_mul_pd(dy, b));
    const __m256d pz = _mm256_sub_pd(oz, _mm256_mul_pd(dz, b));
    const __m256d rr = _mm256_set1_pd(r2);
    const __m256d disc =
        _mm256_sub_pd(rr, _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(px, px), _mm256_mul_pd(py, py)),
                                        _mm256_mul_pd(pz, pz)));
    // Every lane misses (most rays, most spheres): no square root, no division.
    if (_mm256_movemask_pd(_mm256_cmp_pd(disc, zero, _CMP_LT_OQ)) == 0xF)
        return _mm_set1_ps(std::numeric_limits<float>::infinity());
    const __m256d c =
        _mm256_sub_pd(_mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(ox, ox), _mm256_mul_pd(oy, oy)),
                                    _mm256_mul_pd(oz, oz)),
                      rr);
    const __m256d root =
        _mm256_or_pd(_mm256_andnot_pd(sign, _mm256_sqrt_pd(disc)), _mm256_and_pd(sign, b));
    const __m256d q = _mm256_sub_pd(_mm256_xor_pd(b, sign), root);
    const __m256d t0a =
        _mm256_blendv_pd(zero, _mm256_div_pd(c, q), _mm256_cmp_pd(q, zero, _CMP_NEQ_UQ));
    const __m256d swap = _mm256_cmp_pd(t0a, q, _CMP_GT_OQ);
    const __m256d t0 = _mm256_blendv_pd(t0a, q, swap), t1 = _mm256_blendv_pd(q, t0a, swap);
    const __m128 f0 = _mm256_cvtpd_ps(t0), f1 = _mm256_cvtpd_ps(t1);
    const __m128 z = _mm_setzero_ps(), inf = _mm_set1_ps(std::numeric_limits<float>::infinity());
    __m128 t = _mm_blendv_ps(_mm_blendv_ps(inf, f1, _mm_cmpgt_ps(f1, z)), f0, _mm_cmpgt_ps(f0, z));
    if (slip == kRootFar) t = _mm_blendv_ps(inf, f1, _mm_cmpgt_ps(f1, z));
    if (slip == kRootNegative || slip == kRootNearOnly)
        t = _mm_blendv_ps(t, slip == kRootNegative ? f0 : inf, _mm_cmple_ps(f0, z));
    const __m128 miss =
        _mm256_cvtpd_ps(_mm256_cmp_pd(disc, zero, _CMP_LT_OQ));  // all-ones -> NaN: nonzero sign
    return _mm_blendv_ps(t, inf, miss);
}

inline VF robust_candidate(VF ox, VF oy, VF oz, VF dx, VF dy, VF dz, float cx, float cy, float cz,
                           float radius, int slip) {
    const double r2 = double(radius) * radius;
    auto lo = [](__m256 v) { return _mm256_cvtps_pd(_mm256_castps256_ps128(v)); };
    auto hi = [](__m256 v) { return _mm256_cvtps_pd(_mm256_extractf128_ps(v, 1)); };
    const __m256d cxd = _mm256_set1_pd(cx), cyd = _mm256_set1_pd(cy), czd = _mm256_set1_pd(cz);
    const __m128 a = robust4(_mm256_sub_pd(lo(ox.v), cxd), _mm256_sub_pd(lo(oy.v), cyd),
                             _mm256_sub_pd(lo(oz.v), czd), lo(dx.v), lo(dy.v), lo(dz.v), r2, slip);
    const __m128 b = robust4(_mm256_sub_pd(hi(ox.v), cxd), _mm256_sub_pd(hi(oy.v), cyd),
                             _mm256_sub_pd(hi(oz.v), czd), hi(dx.v), hi(dy.v), hi(dz.v), r2, slip);
    return {_mm256_insertf128_ps(_mm256_castps128_ps256(a), b, 1)};
}

#elif RT_SIMD_LEVEL == 2

constexpr int W = 16;
struct VF {
    __m512 v;
};
struct VI {
    __m512i v;
};
using VM = __mmask16;

inline VF operator+(VF a, VF b) { return {_mm512_add_ps(a.v, b.v)}; }
inline VF operator-(VF a, VF b) { return {_mm512_sub_ps(a.v, b.v)}; }
inline VF operator*(VF a, VF b) { return {_mm512_mul_ps(a.v, b.v)}; }
inline VF operator/(VF a, VF b) { return {_mm512_div_ps(a.v, b.v)}; }
inline VF operator-(VF a) {
    return {_mm512_castsi512_ps(
        _mm512_xor_si512(_mm512_castps_si512(a.v), _mm512_set1_epi32(INT32_MIN)))};
}
inline VF vsqrt(VF a) { return {_mm512_sqrt_ps(a.v)}; }
inline VF vabs(VF a) {
    return {_mm512_castsi512_ps(
        _mm512_and_si512(_mm512_castps_si512(a.v), _mm512_set1_epi32(INT32_MAX)))};
}
inline VF fset(float x) { return {_mm512_set1_ps(x)}; }
inline VF fload(const float* p) { return {_mm512_loadu_ps(p)}; }
inline void fstore(float* p, VF a) { _mm512_storeu_ps(p, a.v); }
inline VF fgather(const float* base, VI i) { return {_mm512_i32gather_ps(i.v, base, 4)}; }
inline VF ftable(const float* base, VI i) {
    return {_mm512_permutexvar_ps(i.v, _mm512_loadu_ps(base))};
}
inline VI itable(const int* base, VI i) {
    return {_mm512_permutexvar_epi32(i.v, _mm512_loadu_si512(base))};
}
inline VM lt(VF a, VF b) { return _mm512_cmp_ps_mask(a.v, b.v, _CMP_LT_OQ); }
inline VM le(VF a, VF b) { return _mm512_cmp_ps_mask(a.v, b.v, _CMP_LE_OQ); }
inline VM eq(VF a, VF b) { return _mm512_cmp_ps_mask(a.v, b.v, _CMP_EQ_OQ); }
inline VM isnan_(VF a) { return _mm512_cmp_ps_mask(a.v, a.v, _CMP_UNORD_Q); }
inline VF sel(VM m, VF a, VF b) { return {_mm512_mask_blend_ps(m, b.v, a.v)}; }
inline VF vmax_raw(VF a, VF b) { return {_mm512_max_ps(a.v, b.v)}; }

inline VI iset(int x) { return {_mm512_set1_epi32(x)}; }
inline VI iload(const int* p) { return {_mm512_loadu_si512(p)}; }
inline void istore(int* p, VI a) { _mm512_storeu_si512(p, a.v); }
inline void bstore(unsigned char* p, VI a) {
    _mm_storeu_si128(reinterpret_cast<__m128i*>(p), _mm512_cvtepi32_epi8(a.v));
}
inline VI igather(const int* base, VI i) { return {_mm512_i32gather_epi32(i.v, base, 4)}; }
inline VI iota() {
    return {_mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15)};
}
inline VI iand(VI a, VI b) { return {_mm512_and_si512(a.v, b.v)}; }
inline VM ieq(VI a, VI b) { return _mm512_cmpeq_epi32_mask(a.v, b.v); }
inline VM igt(VI a, VI b) { return _mm512_cmpgt_epi32_mask(a.v, b.v); }
inline VI isel(VM m, VI a, VI b) { return {_mm512_mask_blend_epi32(m, b.v, a.v)}; }
inline VF itof(VI a) { return {_mm512_cvtepi32_ps(a.v)}; }
inline VI ftoi(VF a) { return {_mm512_cvttps_epi32(a.v)}; }
inline VI iadd(VI a, VI b) { return {_mm512_add_epi32(a.v, b.v)}; }

inline VM mand(VM a, VM b) { return static_cast<VM>(a & b); }
inline VM mor(VM a, VM b) { return static_cast<VM>(a | b); }
inline VM mandnot(VM a, VM b) { return static_cast<VM>(a & ~b); }
inline VM mnot(VM a) { return static_cast<VM>(~a); }
inline VM mall(bool b) { return b ? VM(0xFFFF) : VM(0); }
inline bool any(VM m) { return m != 0; }
inline bool all(VM m) { return _kortestc_mask16_u8(m, m) != 0; }  // one kortestw
inline unsigned bits(VM m) { return m; }

// Compress into a register, then one full store: the masked compress-store to memory is slow.
inline void compress_store(float* dst, VM m, VF v) {
    _mm512_storeu_ps(dst, _mm512_maskz_compress_ps(m, v.v));
}
inline void compress_store(int* dst, VM m, VI v) {
    _mm512_storeu_si512(dst, _mm512_maskz_compress_epi32(m, v.v));
}
inline void rank_store(int* dst, VM m, int base) {
    _mm512_mask_storeu_epi32(
        dst, m, _mm512_maskz_expand_epi32(m, _mm512_add_epi32(iota().v, _mm512_set1_epi32(base))));
}
inline VF expand_load(const float* p, VM m) { return {_mm512_maskz_expandloadu_ps(m, p)}; }
inline VF expand_merge(VF src, VM m, const float* p) {
    return {_mm512_mask_expandloadu_ps(src.v, m, p)};
}
inline VM from_bits(unsigned b) { return static_cast<VM>(b); }

inline __m256 robust8(__m512d ox, __m512d oy, __m512d oz, __m512d dx, __m512d dy, __m512d dz,
                      double r2, int slip) {
    const __m512d zero = _mm512_setzero_pd();
    const __m512i sign = _mm512_set1_epi64(INT64_MIN);
    const __m512d b = _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(ox, dx), _mm512_mul_pd(oy, dy)),
                                    _mm512_mul_pd(oz, dz));
    const __m512d px = _mm512_sub_pd(ox, _mm512_mul_pd(dx, b));
    const __m512d py = _mm512_sub_pd(oy, _mm512_mul_pd(dy, b));
    const __m512d pz = _mm512_sub_pd(oz, _mm512_mul_pd(dz, b));
    const __m512d rr = _mm512_set1_pd(r2);
    const __m512d disc =
        _mm512_sub_pd(rr, _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(px, px), _mm512_mul_pd(py, py)),
                                        _mm512_mul_pd(pz, pz)));
    // A miss (disc < 0) as +inf roots: +inf is no candidate below any limit. Every lane a miss
    // (most rays, most spheres): no square root, no division.
    const __mmask8 miss = _mm512_cmp_pd_mask(disc, zero, _CMP_LT_OQ);
    if (miss == 0xFF) return _mm256_set1_ps(std::numeric_limits<float>::infinity());
    const __m512d c =
        _mm512_sub_pd(_mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(ox, ox), _mm512_mul_pd(oy, oy)),
                                    _mm512_mul_pd(oz, oz)),
                      rr);
    const __m512i sq = _mm512_castpd_si512(_mm512_sqrt_pd(disc));
    const __m512i bi = _mm512_castpd_si512(b);
    const __m512d root = _mm512_castsi512_pd(
        _mm512_or_si512(_mm512_andnot_si512(sign, sq), _mm512_and_si512(sign, bi)));
    const __m512d q = _mm512_sub_pd(_mm512_castsi512_pd(_mm512_xor_si512(bi, sign)), root);
    const __m512d t0a =
        _mm512_mask_blend_pd(_mm512_cmp_pd_mask(q, zero, _CMP_NEQ_UQ), zero, _mm512_div_pd(c, q));
    const __mmask8 swap = _mm512_cmp_pd_mask(t0a, q, _CMP_GT_OQ);
    const __m512d dinf = _mm512_set1_pd(std::numeric_limits<double>::infinity());
    const __m512d t0 = _mm512_mask_blend_pd(miss, _mm512_mask_blend_pd(swap, t0a, q), dinf);
    const __m512d t1 = _mm512_mask_blend_pd(miss, _mm512_mask_blend_pd(swap, q, t0a), dinf);
    const __m256 f0 = _mm512_cvtpd_ps(t0), f1 = _mm512_cvtpd_ps(t1);
    const __m256 z = _mm256_setzero_ps(),
                 inf = _mm256_set1_ps(std::numeric_limits<float>::infinity());
    const __m256 t = _mm256_blendv_ps(_mm256_blendv_ps(inf, f1, _mm256_cmp_ps(f1, z, _CMP_GT_OQ)),
                                      f0, _mm256_cmp_ps(f0, z, _CMP_GT_OQ));
    if (slip == kRootPlain) return t;
    if (slip == kRootFar) return _mm256_blendv_ps(inf, f1, _mm256_cmp_ps(f1, z, _CMP_GT_OQ));
    return _mm256_blendv_ps(t, slip == kRootNegative ? f0 : inf, _mm256_cmp_ps(f0, z, _CMP_LE_OQ));
}

inline VF robust_candidate(VF ox, VF oy, VF oz, VF dx, VF dy, VF dz, float cx, float cy, float cz,
                           float radius, int slip) {
    const double r2 = double(radius) * radius;
    auto lo = [](__m512 v) { return _mm512_cvtps_pd(_mm512_castps512_ps256(v)); };
    auto hi = [](__m512 v) {
        return _mm512_cvtps_pd(_mm256_castpd_ps(_mm512_extractf64x4_pd(_mm512_castps_pd(v), 1)));
    };
    const __m512d cxd = _mm512_set1_pd(cx), cyd = _mm512_set1_pd(cy), czd = _mm512_set1_pd(cz);
    const __m256 a = robust8(_mm512_sub_pd(lo(ox.v), cxd), _mm512_sub_pd(lo(oy.v), cyd),
                             _mm512_sub_pd(lo(oz.v), czd), lo(dx.v), lo(dy.v), lo(dz.v), r2, slip);
    const __m256 b = robust8(_mm512_sub_pd(hi(ox.v), cxd), _mm512_sub_pd(hi(oy.v), cyd),
                             _mm512_sub_pd(hi(oz.v), czd), hi(dx.v), hi(dy.v), hi(dz.v), r2, slip);
    return {_mm512_castpd_ps(
        _mm512_insertf64x4(_mm512_castps_pd(_mm512_castps256_ps512(a)), _mm256_castps_pd(b), 1))};
}

#else
#error "RT_SIMD_LEVEL must be 0, 1 or 2"
#endif

// Shared helpers in terms of the above.
inline VF fzero() { return fset(0.0f); }
inline VM gt(VF a, VF b) { return lt(b, a); }
// std::max(0.0f, x) as the scalar code has it: (0 < x) ? x : 0 (NaN -> 0).
inline VF max0(VF x) { return sel(lt(fzero(), x), x, fzero()); }
// std::fmax(a, b): the other operand where one is NaN.
inline VF vfmax(VF a, VF b) { return sel(isnan_(b), a, vmax_raw(a, b)); }
