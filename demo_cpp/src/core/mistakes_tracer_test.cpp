// Named mistakes (mistakes.h) in the tracer, each on a scene small enough to work out by hand.
#include <gtest/gtest.h>

#include "core/mistakes.h"
#include "core/tracer.h"

namespace rt {
namespace {

// A mirror sphere (colour 0.5) straight ahead of the camera, an empty background of 1 behind.
Scene mirror_scene() {
    Scene s;
    s.background = color(1.0f);
    Sphere m;
    m.name = "mirror";
    m.center = {0, 0, -5};
    m.radius = 1;
    m.surface_color = color(0.5f);
    m.reflection = 1;
    s.spheres = {m};
    return s;
}

color trace_with(const Scene& scene, const char* mistakes, const ray& r, int max_depth = 5) {
    TraceOptions o;
    o.max_depth = max_depth;
    o.quirks = quirks_for(Mode::classic);
    o.mistakes = parse_mistake_list(mistakes);
    return Tracer(scene, o).trace(r, 0);
}

const ray kAhead{{0, 0, 0}, {0, 0, -1}};
const ray kMiss{{0, 0, 0}, {0, 0, 1}};

TEST(MistakesInTracer, BlackBackgroundOnAMissAndThroughTheMirror) {
    const Scene scene = mirror_scene();
    EXPECT_EQ(trace_with(scene, "black_background", kMiss).x, 0.0f);
    EXPECT_EQ(trace_with(scene, "black_background", kAhead).x, 0.0f);
}

TEST(MistakesInTracer, FresnelVariantsHeadOn) {
    const Scene scene = mirror_scene();
    // Head-on the paper's curve gives F = 0.1; the reflected background is 1, the colour 0.5.
    EXPECT_NEAR(trace_with(scene, "fresnel_constant", kAhead).x, 0.5f * 0.5f, 1e-6f);
    EXPECT_NEAR(trace_with(scene, "fresnel_missing", kAhead).x, 1.0f * 0.5f, 1e-6f);
    EXPECT_NEAR(trace_with(scene, "fresnel_exponent", kAhead).x, 0.1f * 0.5f, 1e-6f);
}

TEST(MistakesInTracer, DepthCutStopsOneLevelEarly) {
    const Scene scene = mirror_scene();
    // Max depth 1: depth 0 may reflect; with depth_cut it may not (Q6: shaded as diffuse).
    EXPECT_NEAR(trace_with(scene, "fresnel_missing", kAhead, 1).x, 0.5f, 1e-6f);
    const color cut = trace_with(scene, "depth_cut", kAhead, 1);
    EXPECT_EQ(cut.x, 0.0f);  // no light in the scene: a diffuse-shaded sphere is black
}

}  // namespace
}  // namespace rt
