#include "core/sphere.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace rt {
namespace {

Sphere unit_sphere_at(point3 c, float r = 1.0f) {
    Sphere s;
    s.center = c;
    s.radius = r;
    return s;
}

TEST(IntersectPaper, HitsSphereAheadAtNearSide) {
    const auto t = intersect_paper(unit_sphere_at({0, 0, -5}), {{0, 0, 0}, {0, 0, -1}});
    ASSERT_TRUE(t);
    EXPECT_FLOAT_EQ(*t, 4.0f);
}

TEST(IntersectPaper, MissesWhenLineIsFartherThanRadius) {
    EXPECT_FALSE(intersect_paper(unit_sphere_at({0, 1.01f, -5}), {{0, 0, 0}, {0, 0, -1}}));
}

TEST(IntersectPaper, OriginInsideCentreAheadUsesFarRoot) {
    const auto t = intersect_paper(unit_sphere_at({0, 0, -0.5f}), {{0, 0, 0}, {0, 0, -1}});
    ASSERT_TRUE(t);
    EXPECT_FLOAT_EQ(*t, 1.5f);
}

// Q1: with the centre behind the origin the paper gives up, although the ray is inside.
TEST(IntersectPaper, Q1MissesWhenCentreIsBehindOriginEvenFromInside) {
    const Sphere s = unit_sphere_at({0, 0, 0.5f});
    const ray r{{0, 0, 0}, {0, 0, -1}};
    EXPECT_FALSE(intersect_paper(s, r));
    const auto robust = intersect_robust(s, r, {});
    ASSERT_TRUE(robust);
    EXPECT_NEAR(*robust, 0.5f, 1e-6f);
}

TEST(IntersectRobust, RespectsIntervalBounds) {
    const Sphere s = unit_sphere_at({0, 0, -5});
    const ray r{{0, 0, 0}, {0, 0, -1}};
    EXPECT_FALSE(intersect_robust(s, r, {0.0f, 3.9f}));
    const auto far = intersect_robust(s, r, {4.5f, 100.0f});
    ASSERT_TRUE(far);
    EXPECT_NEAR(*far, 6.0f, 1e-5f);
}

// The paper's floor (radius 1e4) seen from its camera: the robust root, evaluated in double,
// equals the float64 one to float rounding (a float32 evaluation was off by ~1e-4 relative,
// enough to flip shadow and horizon pixels against Mitsuba).
TEST(IntersectRobust, HugeSphereMatchesDoublePrecision) {
    const Sphere floor = unit_sphere_at({0, -10004, -20}, 10000);
    std::mt19937 rng(12345);
    std::uniform_real_distribution<float> u(-0.3f, -0.02f), h(-0.3f, 0.3f);
    for (int i = 0; i < 200; ++i) {
        const vec3 d = normalize(vec3{h(rng), u(rng), -1.0f});
        const ray r{{0, 1, 4}, d};
        // float64 reference
        const double ox = 0, oy = 1 + 10004.0, oz = 4 + 20.0;
        const double b = ox * d.x + oy * d.y + oz * d.z;
        const double c = ox * ox + oy * oy + oz * oz - 1e8;
        const double disc = b * b - c;
        if (disc < 1e-4 * b * b) continue;  // above or too close to the horizon to call
        const double t_ref = -b - std::sqrt(disc);
        const auto t = intersect_robust(floor, r, {});
        ASSERT_TRUE(t) << "seed 12345, sample " << i;
        EXPECT_NEAR(*t, t_ref, 1e-6 * t_ref) << "seed 12345, sample " << i;
    }
}

}  // namespace
}  // namespace rt
