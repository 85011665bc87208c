#include "sphere_lanes.h"

#include <immintrin.h>

#include <cmath>
#include <limits>

namespace rt {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// Eight lanes of intersect_paper. Built for AVX2 without FMA so that every product is
// rounded on its own, exactly as the scalar code compiled for baseline x86-64.
__attribute__((target("avx2"))) void lane_t_avx2(const float* cx, const float* cy, const float* cz,
                                                  const float* r2, int padded, const ray& r, float* t) {
    const __m256 ox = _mm256_set1_ps(r.origin.x), oy = _mm256_set1_ps(r.origin.y),
                 oz = _mm256_set1_ps(r.origin.z);
    const __m256 dx = _mm256_set1_ps(r.dir.x), dy = _mm256_set1_ps(r.dir.y), dz = _mm256_set1_ps(r.dir.z);
    const __m256 zero = _mm256_setzero_ps(), inf = _mm256_set1_ps(kInf);
    for (int i = 0; i < padded; i += 8) {
        const __m256 lx = _mm256_sub_ps(_mm256_loadu_ps(cx + i), ox);
        const __m256 ly = _mm256_sub_ps(_mm256_loadu_ps(cy + i), oy);
        const __m256 lz = _mm256_sub_ps(_mm256_loadu_ps(cz + i), oz);
        const __m256 tca = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(lx, dx), _mm256_mul_ps(ly, dy)),
                                         _mm256_mul_ps(lz, dz));
        const __m256 ll = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(lx, lx), _mm256_mul_ps(ly, ly)),
                                        _mm256_mul_ps(lz, lz));
        const __m256 d2 = _mm256_sub_ps(ll, _mm256_mul_ps(tca, tca));
        const __m256 rr = _mm256_loadu_ps(r2 + i);
        const __m256 thc = _mm256_sqrt_ps(_mm256_sub_ps(rr, d2));
        const __m256 t0 = _mm256_sub_ps(tca, thc);
        const __m256 hit_t = _mm256_blendv_ps(t0, _mm256_add_ps(tca, thc), _mm256_cmp_ps(t0, zero, _CMP_LT_OQ));
        // Ordered compares are false on NaN, like the scalar early-outs.
        const __m256 miss = _mm256_or_ps(_mm256_cmp_ps(tca, zero, _CMP_LT_OQ), _mm256_cmp_ps(d2, rr, _CMP_GT_OQ));
        _mm256_storeu_ps(t + i, _mm256_blendv_ps(hit_t, inf, miss));
    }
}

}  // namespace

SphereLanes::SphereLanes(const std::vector<Sphere>& spheres)
    : count_(static_cast<int>(spheres.size())), padded_((count_ + 7) / 8 * 8),
      cx_(padded_, 0.0f), cy_(padded_, 0.0f), cz_(padded_, 0.0f), r2_(padded_, -kInf),
      avx2_(__builtin_cpu_supports("avx2")) {
    for (int i = 0; i < count_; ++i) {
        cx_[i] = spheres[i].center.x;
        cy_[i] = spheres[i].center.y;
        cz_[i] = spheres[i].center.z;
        r2_[i] = spheres[i].radius * spheres[i].radius;
    }
}

void SphereLanes::lane_t(const ray& r, float* t) const {
    if (avx2_) {
        lane_t_avx2(cx_.data(), cy_.data(), cz_.data(), r2_.data(), padded_, r, t);
        return;
    }
    for (int i = 0; i < padded_; ++i) {  // no AVX2: the same test, one lane at a time
        const vec3 l = vec3{cx_[i], cy_[i], cz_[i]} - r.origin;
        const float tca = dot(l, r.dir);
        const float d2 = dot(l, l) - tca * tca;
        if (tca < 0 || d2 > r2_[i]) {
            t[i] = kInf;
            continue;
        }
        const float thc = std::sqrt(r2_[i] - d2);
        const float t0 = tca - thc;
        t[i] = t0 < 0 ? tca + thc : t0;
    }
}

int SphereLanes::nearest_paper(const ray& r, int skip, float* t) const {
    alignas(32) float lanes[kMaxSpheres];
    lane_t(r, lanes);
    int best = -1;
    float t_near = kInf;
    for (int i = 0; i < count_; ++i) {
        if (i != skip && lanes[i] < t_near) {  // strict: the first of equal t wins, as in the loop
            t_near = lanes[i];
            best = i;
        }
    }
    if (best >= 0) *t = t_near;
    return best;
}

std::uint64_t SphereLanes::blockers_paper(const ray& r, float max_t) const {
    alignas(32) float lanes[kMaxSpheres];
    lane_t(r, lanes);
    std::uint64_t mask = 0;
    for (int i = 0; i < count_; ++i)
        if (lanes[i] < max_t) mask |= std::uint64_t{1} << i;
    return mask;
}

}  // namespace rt
