#include "core/sphere_lanes.h"

#include <immintrin.h>

#include <cmath>
#include <limits>

#include "core/cpu_features.h"

namespace rt {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// The ray, broadcast to eight lanes.
struct RayLanes {
    __m256 ox, oy, oz, dx, dy, dz;
};

__attribute__((target("avx2"), always_inline)) inline RayLanes broadcast(const ray& r) {
    return {_mm256_set1_ps(r.origin.x), _mm256_set1_ps(r.origin.y), _mm256_set1_ps(r.origin.z),
            _mm256_set1_ps(r.dir.x),    _mm256_set1_ps(r.dir.y),    _mm256_set1_ps(r.dir.z)};
}

// Eight lanes of intersect_paper: t, +inf where it misses, NaN where the scalar t is NaN.
// Built for AVX2 without FMA so that every product is rounded on its own, exactly as the
// scalar code compiled for baseline x86-64.
__attribute__((target("avx2"), always_inline)) inline __m256 paper_t8(
    const float* cx, const float* cy, const float* cz, const float* r2, const RayLanes& r) {
    const __m256 zero = _mm256_setzero_ps();
    const __m256 lx = _mm256_sub_ps(_mm256_loadu_ps(cx), r.ox);
    const __m256 ly = _mm256_sub_ps(_mm256_loadu_ps(cy), r.oy);
    const __m256 lz = _mm256_sub_ps(_mm256_loadu_ps(cz), r.oz);
    const __m256 tca = _mm256_add_ps(
        _mm256_add_ps(_mm256_mul_ps(lx, r.dx), _mm256_mul_ps(ly, r.dy)), _mm256_mul_ps(lz, r.dz));
    const __m256 ll = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(lx, lx), _mm256_mul_ps(ly, ly)),
                                    _mm256_mul_ps(lz, lz));
    const __m256 d2 = _mm256_sub_ps(ll, _mm256_mul_ps(tca, tca));
    const __m256 rr = _mm256_loadu_ps(r2);
    const __m256 thc = _mm256_sqrt_ps(_mm256_sub_ps(rr, d2));
    const __m256 t0 = _mm256_sub_ps(tca, thc);
    const __m256 t =
        _mm256_blendv_ps(t0, _mm256_add_ps(tca, thc), _mm256_cmp_ps(t0, zero, _CMP_LT_OQ));
    // Ordered compares are false on NaN, like the scalar early-outs.
    const __m256 miss =
        _mm256_or_ps(_mm256_cmp_ps(tca, zero, _CMP_LT_OQ), _mm256_cmp_ps(d2, rr, _CMP_GT_OQ));
    return _mm256_blendv_ps(t, _mm256_set1_ps(kInf), miss);
}

// The nearest lane (lowest index among equal t; NaN, `skip` and padding left out), reduced
// in registers.
__attribute__((target("avx2"))) SphereHit nearest_avx2(const float* cx, const float* cy,
                                                       const float* cz, const float* r2, int count,
                                                       int skip, const ray& ray_in) {
    const RayLanes r = broadcast(ray_in);
    const __m256 inf = _mm256_set1_ps(kInf);
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    SphereHit best{-1, kInf};
    for (int i = 0; i < count; i += 8) {
        __m256 v = paper_t8(cx + i, cy + i, cz + i, r2 + i, r);
        const __m256i index = _mm256_add_epi32(lane, _mm256_set1_epi32(i));
        const __m256i skipped =
            _mm256_or_si256(_mm256_cmpeq_epi32(index, _mm256_set1_epi32(skip)),
                            _mm256_cmpgt_epi32(index, _mm256_set1_epi32(count - 1)));
        v = _mm256_blendv_ps(
            v, inf, _mm256_or_ps(_mm256_castsi256_ps(skipped), _mm256_cmp_ps(v, v, _CMP_UNORD_Q)));
        __m256 m = _mm256_min_ps(v, _mm256_permute2f128_ps(v, v, 1));
        m = _mm256_min_ps(m, _mm256_shuffle_ps(m, m, _MM_SHUFFLE(1, 0, 3, 2)));
        m = _mm256_min_ps(m, _mm256_shuffle_ps(m, m, _MM_SHUFFLE(2, 3, 0, 1)));
        const float chunk_min = _mm256_cvtss_f32(m);
        if (chunk_min < best.t) {  // strict: an earlier chunk keeps its tie
            const unsigned equal =
                static_cast<unsigned>(_mm256_movemask_ps(_mm256_cmp_ps(v, m, _CMP_EQ_OQ)));
            alignas(32) float t[8];
            _mm256_store_ps(t, v);
            const int first = __builtin_ctz(equal);
            best = {i + first, t[first]};  // the lane's own value (-0 and +0 compare equal)
        }
    }
    return best;
}

__attribute__((target("avx2"))) std::uint64_t blockers_avx2(const float* cx, const float* cy,
                                                            const float* cz, const float* r2,
                                                            int padded, float max_t,
                                                            const ray& ray_in) {
    const RayLanes r = broadcast(ray_in);
    const __m256 limit = _mm256_set1_ps(max_t);
    std::uint64_t mask = 0;
    for (int i = 0; i < padded; i += 8) {
        const __m256 t = paper_t8(cx + i, cy + i, cz + i, r2 + i, r);
        mask |= static_cast<std::uint64_t>(_mm256_movemask_ps(_mm256_cmp_ps(t, limit, _CMP_LT_OQ)))
                << i;
    }
    return mask;  // padding lanes are +inf: never below max_t
}

}  // namespace

SphereLanes::SphereLanes(const std::vector<Sphere>& spheres)
    : count_(static_cast<int>(spheres.size())),
      padded_((count_ + 7) / 8 * 8),
      cx_(padded_, 0.0f),
      cy_(padded_, 0.0f),
      cz_(padded_, 0.0f),
      r2_(padded_, -kInf),
      avx2_(cpu_runs_avx2()) {
    for (int i = 0; i < count_; ++i) {
        cx_[i] = spheres[i].center.x;
        cy_[i] = spheres[i].center.y;
        cz_[i] = spheres[i].center.z;
        r2_[i] = spheres[i].radius * spheres[i].radius;
    }
}

float SphereLanes::scalar_t(int i, const ray& r) const {
    return intersect_paper(point3{cx_[i], cy_[i], cz_[i]}, r2_[i], r).value_or(kInf);
}

SphereHit SphereLanes::nearest_paper(const ray& r, int skip) const {
    if (avx2_) return nearest_avx2(cx_.data(), cy_.data(), cz_.data(), r2_.data(), count_, skip, r);
    SphereHit best{-1, kInf};  // no AVX2: the same test, one sphere at a time
    for (int i = 0; i < count_; ++i) {
        const float t = scalar_t(i, r);
        if (i != skip && t < best.t) best = {i, t};  // strict: the first of equal t wins
    }
    return best;
}

std::uint64_t SphereLanes::blockers_paper(const ray& r, float max_t) const {
    if (avx2_)
        return blockers_avx2(cx_.data(), cy_.data(), cz_.data(), r2_.data(), padded_, max_t, r);
    std::uint64_t mask = 0;
    for (int i = 0; i < count_; ++i)
        if (scalar_t(i, r) < max_t) mask |= std::uint64_t{1} << i;
    return mask;
}

void SphereLanes::force_scalar_for_testing() { avx2_ = false; }

}  // namespace rt
