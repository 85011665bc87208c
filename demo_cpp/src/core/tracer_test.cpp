// Shading rules of docs/paper-model.md, each on a scene small enough to work out by hand.
#include "core/tracer.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/fresnel.h"
#include "core/light_units.h"

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

// Paper mode with its direct-light quirks Q11-Q13 fixed too, where a test is about another
// quirk: the colour then starts at 0, each light is weighted by n.l, emission is added.
TraceOptions paper_lit_from_zero(std::initializer_list<Quirk> fixes = {}) {
    TraceOptions o = options_for(Mode::paper, fixes);
    for (Quirk q :
         {Quirk::lit_colour_starts_at_one, Quirk::no_lambert_cosine, Quirk::no_own_emission})
        o.quirks.fix(q);
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
    TraceOptions o = paper_lit_from_zero();
    o.max_depth = 0;
    // p = (0,0,-4), n = +z, l = normalize(0,5,4): colour * E * n.l
    const float expected = 0.5f * 4.0f / std::sqrt(41.0f);
    EXPECT_NEAR(Tracer(scene, o).trace({{0, 0, 0}, {0, 0, -1}}, 0).x, expected, 1e-6f);
    o.quirks.fix(Quirk::diffuse_at_max_depth);
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
    EXPECT_EQ(Tracer(scene, paper_lit_from_zero()).shade_direct(0, p, n).x, 0.0f);
    EXPECT_NEAR(
        Tracer(scene, paper_lit_from_zero({Quirk::shadow_rays_pass_light})).shade_direct(0, p, n).x,
        0.8f, 1e-6f);
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
    EXPECT_NEAR(Tracer(scene, paper_lit_from_zero()).shade_direct(0, p, n).x,
                0.8f * 0.5f * cos_theta, 1e-5f);
    // Q4 fixed: each light gets its own product of transmissions, 0.5 each.
    EXPECT_NEAR(
        Tracer(scene, paper_lit_from_zero({Quirk::shared_shadow_factor})).shade_direct(0, p, n).x,
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
    EXPECT_NEAR(Tracer(scene, paper_lit_from_zero()).shade_direct(0, {0, 0, -5}, {0, 1, 0}).x,
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

TEST(Tracer, ClassicLightSphereShowsItsEmission) {
    const Scene scene = mirror_scene();
    const Tracer t(scene, options_for(Mode::classic));
    const color c = t.trace({{0, 0, 0}, {0, 1, 0}}, 0);
    EXPECT_NEAR(c.x, 1.0f, 1e-6f);  // black surface, diffuse term 0, plus emission 1
}

// The ground point p = (0,0,-5) (normal +y) under one light of emission 1 at (3,5,-5):
// n.l = 5/sqrt(34).
Scene ground_lit_at_an_angle() {
    Scene scene = ground_scene();
    scene.spheres.push_back(make_light("light", {3, 5, -5}, 1.0f));
    return scene;
}
const point3 kGroundTop{0, 0, -5};
const vec3 kUp{0, 1, 0};

TEST(Tracer, Q11DirectLightStartsAtOne) {
    const Scene scene = ground_lit_at_an_angle();
    const float lit = 0.8f * 5.0f / std::sqrt(34.0f);
    EXPECT_NEAR(Tracer(scene, paper_lit_from_zero()).shade_direct(0, kGroundTop, kUp).x, lit,
                1e-6f);
    TraceOptions q11 = paper_lit_from_zero();
    q11.quirks.add(Quirk::lit_colour_starts_at_one);
    EXPECT_NEAR(Tracer(scene, q11).shade_direct(0, kGroundTop, kUp).x, 1.0f + lit, 1e-6f);
    // With no light at all a diffuse surface is white (background 0 here).
    const Scene dark = ground_scene();
    EXPECT_EQ(Tracer(dark, q11).trace({{0, 3, -5}, {0, -1, 0}}, 0).x, 1.0f);
    EXPECT_EQ(Tracer(dark, paper_lit_from_zero()).trace({{0, 3, -5}, {0, -1, 0}}, 0).x, 0.0f);
    // The physical light terms add to 1 the same way (look_at = p: the light gives E n.l).
    TraceOptions physical = options_for(Mode::physical);
    const float physical_lit = Tracer(scene, physical).shade_direct(0, kGroundTop, kUp).x;
    EXPECT_NEAR(physical_lit, lit, 1e-4f);  // the shadow ray's offset origin moves l a little
    physical.quirks.add(Quirk::lit_colour_starts_at_one);
    EXPECT_EQ(Tracer(scene, physical).shade_direct(0, kGroundTop, kUp).x, 1.0f + physical_lit);
}

TEST(Tracer, Q12NoLambertCosine) {
    const Scene scene = ground_lit_at_an_angle();
    TraceOptions q12 = paper_lit_from_zero();
    q12.quirks.add(Quirk::no_lambert_cosine);
    EXPECT_NEAR(Tracer(scene, q12).shade_direct(0, kGroundTop, kUp).x, 0.8f, 1e-6f);
    // Physical light with no cosine: the full E at look_at.
    TraceOptions physical = options_for(Mode::physical);
    physical.quirks.add(Quirk::no_lambert_cosine);
    EXPECT_NEAR(Tracer(scene, physical).shade_direct(0, kGroundTop, kUp).x, 0.8f, 1e-5f);
}

TEST(Tracer, Q12LightBehindTheSurfaceIsTestedAndShadowedByTheHitSphere) {
    Scene scene = ground_scene();
    scene.spheres.push_back(make_light("below", {0, -5, -5}, 1.0f));
    TraceOptions o =
        paper_lit_from_zero({Quirk::shared_shadow_factor});  // Q4 alone would cast it anyway
    const Tracer fixed(scene, o);
    EXPECT_EQ(fixed.shade_direct(0, kGroundTop, kUp).x, 0.0f);
    EXPECT_EQ(fixed.ray_counts().shadow, 0u);  // n.l <= 0: no shadow ray
    o.quirks.add(Quirk::no_lambert_cosine);
    const Tracer q12(scene, o);
    // Cast now; under Q1 the ground itself lies on the shadow ray and blocks it.
    EXPECT_EQ(q12.shade_direct(0, kGroundTop, kUp).x, 0.0f);
    EXPECT_EQ(q12.ray_counts().shadow, 1u);
    o.shadows = false;  // unblocked, the light below adds its full colour * E
    EXPECT_NEAR(Tracer(scene, o).shade_direct(0, kGroundTop, kUp).x, 0.8f, 1e-6f);
}

// A light sphere of colour 0.5 and emission 2 straight ahead, the only sphere.
Scene light_ahead() {
    Scene scene;
    scene.background = color(0.0f);
    Sphere light = make_light("light", {0, 0, -5}, 2.0f);
    light.surface_color = color(0.5f);
    scene.spheres = {light};
    return scene;
}

TEST(Tracer, Q13LightSphereSeenDirectlyAddsNoEmission) {
    const Scene scene = light_ahead();
    const ray ahead{{0, 0, 0}, {0, 0, -1}};
    // It lights itself only from behind its surface: n.l = -1, so 0 from the light terms.
    EXPECT_EQ(Tracer(scene, paper_lit_from_zero()).trace(ahead, 0).x, 2.0f);
    TraceOptions q13 = paper_lit_from_zero();
    q13.quirks.add(Quirk::no_own_emission);
    EXPECT_EQ(Tracer(scene, q13).trace(ahead, 0).x, 0.0f);
    // Physical: its radiance I/(pi R^2), or with Q13 shaded like a surface (0 here too).
    TraceOptions physical = options_for(Mode::physical);
    EXPECT_EQ(Tracer(scene, physical).trace(ahead, 0).x,
              sphere_radiance(scene, scene.spheres[0]).x);
    physical.quirks.add(Quirk::no_own_emission);
    EXPECT_EQ(Tracer(scene, physical).trace(ahead, 0).x, 0.0f);
    // Paper mode: 1, plus its own light at full strength (Q12: no cosine, and its shadow ray
    // skips the light itself), and no emission: 1 + 0.5 * 2.
    EXPECT_NEAR(Tracer(scene, options_for(Mode::paper)).trace(ahead, 0).x, 2.0f, 1e-6f);
}

TEST(Tracer, PaperLitDiffuseIsOnePlusColourTimesLight) {
    const Scene scene = ground_lit_at_an_angle();
    const Tracer paper(scene, options_for(Mode::paper));
    EXPECT_NEAR(paper.shade_direct(0, kGroundTop, kUp).x, 1.0f + 0.8f, 1e-6f);
    EXPECT_NEAR(paper.trace({{0, 3, -5}, {0, -1, 0}}, 0).x, 1.0f + 0.8f, 1e-6f);
}

}  // namespace
}  // namespace rt
