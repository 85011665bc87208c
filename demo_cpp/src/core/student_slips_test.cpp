#include "core/student_slips.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/camera_rays.h"

namespace rt {
namespace {

MistakeSet with(Mistake m) {
    MistakeSet s;
    s.add(m);
    return s;
}

// A unit sphere at the origin, the ray starting at its centre: t0 = -1, t1 = 1.
const Sphere kSphere = [] {
    Sphere s;
    s.center = {0, 0, 0};
    s.radius = 1;
    return s;
}();
const ray kFromInside{{0, 0, 0}, {0, 0, -1}};

TEST(StudentSlips, RootSlipsChangeOnlyARayThatStartsInside) {
    EXPECT_FLOAT_EQ(*intersect_with_root_slip(kSphere, kFromInside, MistakeSet{}), 1.0f);
    EXPECT_FALSE(intersect_with_root_slip(kSphere, kFromInside, with(Mistake::near_root_only)));
    EXPECT_FLOAT_EQ(
        *intersect_with_root_slip(kSphere, kFromInside, with(Mistake::negative_root_hit)), -1.0f);
    const ray from_outside{{0, 0, 3}, {0, 0, -1}};
    for (Mistake m : {Mistake::near_root_only, Mistake::negative_root_hit})
        EXPECT_FLOAT_EQ(*intersect_with_root_slip(kSphere, from_outside, with(m)), 2.0f);
}

TEST(StudentSlips, ReflectWithTheWrongSignKeepsGoingIntoTheSurface) {
    const vec3 d = normalize(vec3{1, -1, 0}), n{0, 1, 0};
    const vec3 wrong = reflect_wrong_sign(d, n);
    EXPECT_LT(dot(wrong, n), 0.0f);
    // d + 2(d.n)n = (1, -1, 0)/sqrt2 + 2 (-1/sqrt2) (0, 1, 0) = (1, -3, 0)/sqrt2, normalised.
    EXPECT_NEAR(wrong.x, 1.0f / std::sqrt(10.0f), 1e-6f);
    EXPECT_NEAR(wrong.y, -3.0f / std::sqrt(10.0f), 1e-6f);
}

TEST(StudentSlips, LightDirectionSlips) {
    const vec3 to_light{0, 3, 4};
    EXPECT_FLOAT_EQ(light_direction(MistakeSet{}, to_light, 5).y, 0.6f);
    EXPECT_FLOAT_EQ(light_direction(with(Mistake::light_dir_reversed), to_light, 5).y, -0.6f);
    EXPECT_FLOAT_EQ(light_direction(with(Mistake::shadow_dir_unnormalized), to_light, 5).z, 4.0f);
}

TEST(StudentSlips, MixSlipsMoveTheTintAndTheWeights) {
    const SpecularParts parts{color(1.0f), color(1.0f)};
    const MixWeights w{0.5f, 1.0f, color{0.5f, 1.0f, 1.0f}};
    // Right: (1 * 0.3 + 1 * 0.7 * 0.5) * 0.5 = 0.325 in red.
    EXPECT_FLOAT_EQ(mix_with_slip(with(Mistake::reflection_untinted), parts, 0.3f, w).x,
                    0.3f + 0.35f * 0.5f);
    EXPECT_FLOAT_EQ(mix_with_slip(with(Mistake::fresnel_weights_swapped), parts, 0.3f, w).x,
                    (0.7f + 0.15f) * 0.5f);
    EXPECT_FLOAT_EQ(mix_with_slip(with(Mistake::refraction_unweighted), parts, 0.3f, w).x,
                    (0.3f + 0.7f) * 0.5f);
}

TEST(StudentSlips, CameraSlips) {
    Camera cam;
    cam.position = {0, 0, 0};
    cam.look_at = {0, 0, -1};
    cam.up = {0, 1, 0};
    cam.fov_y = 90;
    // The right edge of a 200x100 image at fov_y 90: x = tan(45) * aspect 2 = 2, or 1 without
    // the aspect ratio.
    const ray right = CameraRays(cam, 200, 100).render_from_camera(200, 50);
    const ray squeezed =
        CameraRays(cam, 200, 100, {true, false, false, std::nullopt}).render_from_camera(200, 50);
    EXPECT_NEAR(right.dir.x / -right.dir.z, 2.0f, 1e-5f);
    EXPECT_NEAR(squeezed.dir.x / -squeezed.dir.z, 1.0f, 1e-5f);
    // At fov_y 60 the full angle gives tan(60) where tan(30) belongs: three times as wide.
    cam.fov_y = 60;
    const ray half = CameraRays(cam, 200, 100).render_from_camera(200, 50);
    const ray wide =
        CameraRays(cam, 200, 100, {false, true, false, std::nullopt}).render_from_camera(200, 50);
    EXPECT_NEAR((wide.dir.x / -wide.dir.z) / (half.dir.x / -half.dir.z), 3.0f, 1e-4f);
    cam.fov_y = 90;
    const ray raw =
        CameraRays(cam, 200, 100, {false, false, true, std::nullopt}).render_from_camera(200, 50);
    EXPECT_NEAR(length(raw.dir), std::sqrt(5.0f), 1e-5f);
}

// A camera map (rtdemo --camera-map) gives any such camera: the scene's own numbers give its
// rays, a field of view of 35 the rays of a 35-degree camera, and a row divided by the width
// (v = (1 - 2 py / W) tan) the map sv = tan H / W, ov = tan (1 - H / W).
TEST(StudentSlips, CameraMapGivesTheCameraItDescribes) {
    Camera cam;
    cam.fov_y = 30;
    const float t30 = std::tan(15.0f * 3.14159265358979f / 180.0f);
    const float t35 = std::tan(17.5f * 3.14159265358979f / 180.0f);
    Camera wider = cam;
    wider.fov_y = 35;
    const CameraMap own{t30 * 2.0f, 0.0f, t30, 0.0f}, at35{t35 * 2.0f, 0.0f, t35, 0.0f};
    const CameraMap by_width{t30 * 2.0f, 0.0f, t30 * 0.5f, t30 * 0.5f};
    for (float px : {0.5f, 63.5f, 199.5f})
        for (float py : {0.5f, 50.0f, 99.5f}) {
            const vec3 a = CameraRays(cam, 200, 100).render_from_camera(px, py).dir;
            const vec3 b = CameraRays(cam, 200, 100, {false, false, false, own})
                               .render_from_camera(px, py)
                               .dir;
            EXPECT_NEAR(length(a - b), 0.0f, 1e-6f) << px << "," << py;
            const vec3 c = CameraRays(wider, 200, 100).render_from_camera(px, py).dir;
            const vec3 d = CameraRays(cam, 200, 100, {false, false, false, at35})
                               .render_from_camera(px, py)
                               .dir;
            EXPECT_NEAR(length(c - d), 0.0f, 1e-6f) << px << "," << py;
            const vec3 e = CameraRays(cam, 200, 100, {false, false, false, by_width})
                               .render_from_camera(px, py)
                               .dir;
            EXPECT_NEAR(e.y / -e.z, (1.0f - 2.0f * py / 200.0f) * t30, 1e-5f) << py;
        }
}

}  // namespace
}  // namespace rt
