// The scene's spheres in structure-of-arrays lanes, and the paper's ray test (quirk Q1
// present: paper and classic modes) against eight of them per AVX2 instruction. Results are
// bit for bit those of looping intersect_paper over the spheres in order (same operations,
// same order, no fused multiply-add), which sphere_lanes_test.cpp checks.
#pragma once

#include <cstdint>
#include <vector>

#include "core/sphere.h"

namespace rt {

// The nearest sphere along a ray. Returned by value (two registers): writing the fields
// through pointers and reloading the pair stalled store forwarding in the tracer's hot loop.
struct SphereHit {
    int index = -1;  // -1: the ray hits nothing
    float t = 0.0f;
    explicit operator bool() const { return index >= 0; }
};

class SphereLanes {
public:
    static constexpr int kMaxSpheres = 64;  // blockers_paper answers in a 64-bit mask

    explicit SphereLanes(const std::vector<Sphere>& spheres);
    // False for scenes of more than kMaxSpheres spheres: the tracer loops instead.
    bool usable() const { return count_ <= kMaxSpheres; }

    // Nearest sphere by the paper's test, `skip` (or -1) left out.
    SphereHit nearest_paper(const ray& r, int skip) const;
    // Bit j set: the paper's test hits sphere j at t < max_t (a shadow-ray blocker).
    std::uint64_t blockers_paper(const ray& r, float max_t) const;

    // The one-sphere-at-a-time path that CPUs without AVX2 take, for its own test.
    void force_scalar_for_testing();

private:
    // The paper-test t of sphere i (+inf where it misses; NaN stays NaN).
    float scalar_t(int i, const ray& r) const;

    int count_ = 0;
    int padded_ = 0;  // a multiple of 8; padding lanes never hit (r2 = -inf)
    std::vector<float> cx_, cy_, cz_, r2_;
    bool avx2_ = false;
};

}  // namespace rt
