#include "core/sphere_lanes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>

namespace rt {
namespace {

// The loop the lanes replace: intersect_paper over the spheres in order, strict `<`.
int nearest_by_loop(const std::vector<Sphere>& spheres, const ray& r, int skip, float* t) {
    int best = -1;
    float t_near = std::numeric_limits<float>::infinity();
    for (int i = 0; i < static_cast<int>(spheres.size()); ++i) {
        if (i == skip) continue;
        const auto hit = intersect_paper(spheres[i], r);
        if (hit && *hit < t_near) {
            t_near = *hit;
            best = i;
        }
    }
    if (best >= 0) *t = t_near;
    return best;
}

std::vector<Sphere> random_spheres(std::mt19937& rng, int n) {
    std::uniform_real_distribution<float> pos(-6.0f, 6.0f), rad(0.2f, 3.0f);
    std::vector<Sphere> spheres(n);
    for (Sphere& s : spheres) {
        s.center = {pos(rng), pos(rng), pos(rng) - 12.0f};
        s.radius = rad(rng);
    }
    if (n > 0) {  // the paper's floor: a huge sphere, where rounding matters most
        spheres[0].center = {0.0f, -10004.0f, -20.0f};
        spheres[0].radius = 10000.0f;
    }
    return spheres;
}

std::uint32_t bits(float f) {
    std::uint32_t b;
    std::memcpy(&b, &f, sizeof b);
    return b;
}

TEST(SphereLanes, NearestMatchesTheScalarLoopBitForBit) {
    std::mt19937 rng(2026);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f), o(-3.0f, 3.0f);
    for (int n : {1, 3, 7, 8, 9, 16, 64}) {
        const std::vector<Sphere> spheres = random_spheres(rng, n);
        SphereLanes lanes(spheres);
        SphereLanes scalar(spheres);
        scalar.force_scalar_for_testing();
        ASSERT_TRUE(lanes.usable());
        int hits = 0;
        for (int k = 0; k < 4000; ++k) {
            const ray r{{o(rng), o(rng), o(rng)}, normalize(vec3{u(rng), u(rng), -1.0f})};
            const int skip = k % 5 == 0 ? k % n : -1;
            float t_loop = -1;
            const int a = nearest_by_loop(spheres, r, skip, &t_loop);
            const SphereHit b = lanes.nearest_paper(r, skip);
            ASSERT_EQ(a, b.index) << "n " << n << " ray " << k;
            if (a >= 0) {
                ASSERT_EQ(bits(t_loop), bits(b.t)) << "n " << n << " ray " << k;
            }
            const SphereHit c = scalar.nearest_paper(r, skip);
            ASSERT_EQ(a, c.index) << "scalar path, n " << n << " ray " << k;
            if (a >= 0) {
                ASSERT_EQ(bits(t_loop), bits(c.t)) << "scalar path, n " << n << " ray " << k;
            }
            hits += a >= 0;
        }
        EXPECT_GT(hits, 400) << n;  // the rays do meet spheres
    }
}

TEST(SphereLanes, BlockersMatchTheScalarTest) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f), o(-3.0f, 3.0f), far(0.5f, 40.0f);
    const std::vector<Sphere> spheres = random_spheres(rng, 12);
    const SphereLanes lanes(spheres);
    SphereLanes scalar(spheres);
    scalar.force_scalar_for_testing();
    for (int k = 0; k < 4000; ++k) {
        const ray r{{o(rng), o(rng), o(rng)}, normalize(vec3{u(rng), u(rng), -1.0f})};
        const float max_t = k % 3 == 0 ? std::numeric_limits<float>::infinity() : far(rng);
        std::uint64_t expected = 0;
        for (int j = 0; j < 12; ++j) {
            const auto t = intersect_paper(spheres[j], r);
            if (t && *t < max_t) expected |= std::uint64_t{1} << j;
        }
        ASSERT_EQ(lanes.blockers_paper(r, max_t), expected) << "ray " << k;
        ASSERT_EQ(scalar.blockers_paper(r, max_t), expected) << "scalar path, ray " << k;
    }
}

TEST(SphereLanes, NanRayHitsNothingAsInTheLoop) {
    std::mt19937 rng(1);
    const std::vector<Sphere> spheres = random_spheres(rng, 5);
    const SphereLanes lanes(spheres);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const ray r{{0, 0, 0}, {nan, nan, nan}};  // classic mode's Q3 can make such rays
    float t = 7;
    EXPECT_EQ(lanes.nearest_paper(r, -1).index, nearest_by_loop(spheres, r, -1, &t));
    EXPECT_EQ(lanes.nearest_paper(r, -1).index, -1);
    EXPECT_EQ(lanes.blockers_paper(r, std::numeric_limits<float>::infinity()), 0u);
}

TEST(SphereLanes, MoreThanSixtyFourSpheresAreLeftToTheLoop) {
    std::mt19937 rng(3);
    EXPECT_FALSE(SphereLanes(random_spheres(rng, 65)).usable());
}

}  // namespace
}  // namespace rt
