// The scene's spheres in structure-of-arrays lanes, and the paper's ray test (quirk Q1
// present: paper and classic modes) against eight of them per AVX2 instruction. Results are
// bit for bit those of looping intersect_paper over the spheres in order (same operations,
// same order, no fused multiply-add), which sphere_lanes_test.cpp checks.
#pragma once

#include <cstdint>
#include <vector>

#include "sphere.h"

namespace rt {

class SphereLanes {
public:
    static constexpr int kMaxSpheres = 64;  // blockers_paper answers in a 64-bit mask

    explicit SphereLanes(const std::vector<Sphere>& spheres);
    // False for scenes of more than kMaxSpheres spheres: the tracer loops instead.
    bool usable() const { return count_ <= kMaxSpheres; }

    // Nearest sphere by the paper's test, `skip` (or -1) left out: its index, or -1 and t
    // untouched.
    int nearest_paper(const ray& r, int skip, float* t) const;
    // Bit j set: the paper's test hits sphere j at t < max_t (a shadow-ray blocker).
    std::uint64_t blockers_paper(const ray& r, float max_t) const;

private:
    // Paper-test t of every lane (+inf where it misses; NaN stays NaN, as in the scalar test).
    void lane_t(const ray& r, float* t) const;

    int count_ = 0;
    int padded_ = 0;  // a multiple of 8; padding lanes never hit (r2 = -inf)
    std::vector<float> cx_, cy_, cz_, r2_;
    bool avx2_ = false;
};

}  // namespace rt
