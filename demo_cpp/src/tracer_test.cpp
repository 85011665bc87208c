// Shading rules of docs/paper-model.md, each on a scene small enough to work out by hand.
#include "tracer.h"

#include <gtest/gtest.h>

#include <cmath>

#include "fresnel.h"

namespace rt {
namespace {

Sphere make_sphere(const char* name, point3 c, float r, color col) {
    Sphere s;
    s.name = name;
    s.center = c;
    s.radius = r;
    s.surface_color = col;
    return s;
}

Sphere make_light(const char* name, point3 c, float e) {
    Sphere s = make_sphere(name, c, 0.5f, {0, 0, 0});
    s.emission = color(e);
    return s;
}

TraceOptions options_for(Mode mode, std::initializer_list<Quirk> fixes = {}) {
    TraceOptions o;
    o.quirks = quirks_for(mode);
    for (Quirk q : fixes) o.quirks.fix(q);
    return o;
}

// A mirror sphere straight ahead; its reflection looks back into the empty background.
Scene mirror_scene() {
    Scene s;
    s.background = color(1.0f);
    Sphere m = make_sphere("mirror", {0, 0, -5}, 1, color(0.5f));
    m.reflection = 1;
    s.spheres = {m, make_light("light", {0, 5, 0}, 1.0f)};
    return s;
}

TEST(Tracer, PaperMirrorWeightsReflectionByFresnelMix) {
    const Scene scene = mirror_scene();
    const Tracer paper(scene, options_for(Mode::paper));
    const color c = paper.trace({{0, 0, 0}, {0, 0, -1}}, 0);
    // Facing the viewer: F = 0.1; colour = background * F * surface colour.
    EXPECT_NEAR(c.x, 1.0f * 0.1f * 0.5f, 1e-6f);
}

TEST(Tracer, PhysicalMirrorReflectsItsColourExactly) {
    const Scene scene = mirror_scene();
    const Tracer physical(scene, options_for(Mode::physical));
    EXPECT_NEAR(physical.trace({{0, 0, 0}, {0, 0, -1}}, 0).x, 0.5f, 1e-6f);
}

TEST(Tracer, Q6SpecularAtMaxDepthIsShadedAsDiffuse) {
    const Scene scene = mirror_scene();
    TraceOptions o = options_for(Mode::paper);
    o.max_depth = 0;
    // p = (0,0,-4), n = +z, l = normalize(0,5,4): colour * E * n.l
    const float expected = 0.5f * 4.0f / std::sqrt(41.0f);
    EXPECT_NEAR(Tracer(scene, o).trace({{0, 0, 0}, {0, 0, -1}}, 0).x, expected, 1e-6f);
    o.quirks.fix(Quirk::Q6);
    EXPECT_EQ(Tracer(scene, o).trace({{0, 0, 0}, {0, 0, -1}}, 0).x, 0.0f);
}

// A diffuse ground point p = (0,0,-5) with normal +y, and whatever lights a test adds.
Scene ground_scene() {
    Scene s;
    s.background = color(0.0f);
    s.camera.look_at = {0, 0, -5};
    s.spheres = {make_sphere("ground", {0, -1, -5}, 1, color(0.8f))};
    return s;
}

TEST(Tracer, Q5OccluderBeyondTheLightStillShadows) {
    Scene scene = ground_scene();
    scene.spheres.push_back(make_light("light", {0, 5, -5}, 1.0f));
    scene.spheres.push_back(make_sphere("beyond", {0, 10, -5}, 1, color(1.0f)));
    const point3 p{0, 0, -5};
    const vec3 n{0, 1, 0};
    EXPECT_EQ(Tracer(scene, options_for(Mode::paper)).shade_direct(0, p, n).x, 0.0f);
    EXPECT_NEAR(Tracer(scene, options_for(Mode::paper, {Quirk::Q5})).shade_direct(0, p, n).x, 0.8f,
                1e-6f);
}

// Two lights, each behind its own half-transparent glass occluder.
Scene two_lights_two_glass_occluders() {
    Scene scene = ground_scene();
    scene.spheres.push_back(make_light("light_a", {-3, 5, -5}, 1.0f));
    scene.spheres.push_back(make_light("light_b", {3, 5, -5}, 1.0f));
    for (float x : {-1.5f, 1.5f}) {
        Sphere glass = make_sphere(x < 0 ? "glass_a" : "glass_b", {x, 2.5f, -5}, 0.3f, color(1.0f));
        glass.transparency = 0.5f;
        scene.spheres.push_back(glass);
    }
    return scene;
}

TEST(Tracer, Q4SharedShadowFactorCompoundsAcrossLights) {
    const Scene scene = two_lights_two_glass_occluders();
    const point3 p{0, 0, -5};
    const vec3 n{0, 1, 0};
    const float cos_theta = 5.0f / std::sqrt(34.0f);
    // Paper: light A passes 0.5; the shared factor then drops to 0 for light B.
    EXPECT_NEAR(Tracer(scene, options_for(Mode::paper)).shade_direct(0, p, n).x,
                0.8f * 0.5f * cos_theta, 1e-5f);
    // Q4 fixed: each light gets its own product of transmissions, 0.5 each.
    EXPECT_NEAR(Tracer(scene, options_for(Mode::paper, {Quirk::Q4})).shade_direct(0, p, n).x,
                0.8f * (0.5f + 0.5f) * cos_theta, 1e-5f);
    // Q9 fixed as well (the classic program's binary shadows): glass blocks completely.
    EXPECT_EQ(Tracer(scene, options_for(Mode::classic)).shade_direct(0, p, n).x, 0.0f);
}

TEST(Tracer, ShadowSwitchOffIgnoresOccluders) {
    const Scene scene = two_lights_two_glass_occluders();
    TraceOptions o = options_for(Mode::classic);
    o.shadows = false;
    const float cos_theta = 5.0f / std::sqrt(34.0f);
    EXPECT_NEAR(Tracer(scene, o).shade_direct(0, {0, 0, -5}, {0, 1, 0}).x, 0.8f * 2 * cos_theta,
                1e-5f);
}

TEST(Tracer, Q7PhysicalLightFallsOffAndIsCalibratedAtLookAt) {
    Scene scene = ground_scene();
    scene.spheres.push_back(make_light("light", {0, 5, -5}, 2.0f));
    const Tracer physical(scene, options_for(Mode::physical));
    // look_at = p: the calibration makes a white Lambertian surface there receive E.
    EXPECT_NEAR(physical.shade_direct(0, {0, 0, -5}, {0, 1, 0}).x, 0.8f * 2.0f, 1e-5f);
    // Calibrated at a look_at twice as far from the light: p gets (10/5)^2 = 4 times E,
    // where the paper's light (no falloff) would give E wherever p is.
    scene.camera.look_at = {0, -5, -5};
    EXPECT_NEAR(Tracer(scene, options_for(Mode::physical)).shade_direct(0, {0, 0, -5}, {0, 1, 0}).x,
                0.8f * 2.0f * 4.0f, 1e-4f);
    EXPECT_NEAR(Tracer(scene, options_for(Mode::paper)).shade_direct(0, {0, 0, -5}, {0, 1, 0}).x,
                0.8f * 2.0f, 1e-6f);
}

// Inside a glass sphere at a grazing exit: k < 0.
Scene grazing_exit_scene() {
    Scene s;
    s.background = {0.25f, 0.5f, 0.75f};
    Sphere glass = make_sphere("glass", {0, 0, 0}, 1, color(1.0f));
    glass.transparency = 1;
    glass.ior = 1.5f;
    s.spheres = {glass};
    return s;
}

TEST(Tracer, Q3ClassicNaNRayEscapesToTheBackgroundAsInTheOriginal) {
    const Scene scene = grazing_exit_scene();
    const ray r{{0.9f, 0, 0}, {0, 0, -1}};
    TraceOptions on = options_for(Mode::classic);
    on.max_depth = 1;  // the reflected ray then adds nothing (no lights): isolate refraction
    TraceOptions off = on;
    off.refraction = false;
    const color with = Tracer(scene, on).trace(r, 0);
    const color without = Tracer(scene, off).trace(r, 0);
    // The NaN direction fails every IEEE comparison, so it hits nothing: background.
    const float facing = std::sqrt(1.0f - 0.81f);
    const float fresnel = paper_fresnel(facing);
    EXPECT_TRUE(std::isfinite(with.z));
    EXPECT_NEAR(with.z - without.z, (1.0f - fresnel) * 0.75f, 1e-5f);
}

TEST(Tracer, Q3FixedTotalInternalReflectionRefractsNothing) {
    const Scene scene = grazing_exit_scene();
    const ray r{{0.9f, 0, 0}, {0, 0, -1}};
    TraceOptions on = options_for(Mode::physical), off = on;
    off.refraction = false;
    EXPECT_EQ(Tracer(scene, on).trace(r, 0).z, Tracer(scene, off).trace(r, 0).z);
}

TEST(Tracer, PrimaryHitGivesIdDepthAndNormalFacingTheCamera) {
    const Scene scene = mirror_scene();
    const Tracer t(scene, options_for(Mode::paper));
    const PrimaryHit hit = t.primary({{0, 0, 0}, {0, 0, -1}});
    EXPECT_EQ(hit.id, 0);
    EXPECT_NEAR(hit.depth, 4.0f, 1e-6f);
    EXPECT_NEAR(hit.normal.z, 1.0f, 1e-6f);
    EXPECT_EQ(t.primary({{0, 0, 0}, {0, 0, 1}}).id, -1);
}

TEST(Tracer, TraceReportsTheSameFirstHitAsPrimary) {
    const Scene scene = mirror_scene();
    const Tracer t(scene, options_for(Mode::paper));
    for (const vec3 d : {vec3{0, 0, -1}, normalize(vec3{0.1f, 0.05f, -1}), vec3{0, 0, 1}}) {
        PrimaryHit first;
        t.trace({{0, 0, 0}, d}, 0, &first);
        const PrimaryHit p = t.primary({{0, 0, 0}, d});
        EXPECT_EQ(first.id, p.id);
        EXPECT_EQ(first.depth, p.depth);
        EXPECT_EQ(first.normal.z, p.normal.z);
    }
}

TEST(Tracer, PaperLightSphereShowsItsEmission) {
    const Scene scene = mirror_scene();
    const Tracer t(scene, options_for(Mode::paper));
    const color c = t.trace({{0, 0, 0}, {0, 1, 0}}, 0);
    EXPECT_NEAR(c.x, 1.0f, 1e-6f);  // black surface, diffuse term 0, plus emission 1
}

}  // namespace
}  // namespace rt
