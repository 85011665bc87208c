// trace-pixel's tree against the render: the recorded tree's colour is the rendered pixel,
// bit for bit, and the path bits name what the pixel's rays really met.
#include "core/pixel_trace.h"

#include <gtest/gtest.h>

#include <cstring>
#include <string>

#include "core/mistakes.h"
#include "io/scene_loader.h"

namespace rt {
namespace {

const std::string kScenes = RTVAL_SCENES_DIR;

RenderSettings small_settings(Mode mode, const std::string& mistakes, Engine engine) {
    RenderSettings s;
    s.trace.quirks = quirks_for(mode);
    if (!mistakes.empty()) s.trace.mistakes = parse_mistake_list(mistakes);
    s.trace.max_depth = 5;
    s.width = 80;
    s.height = 60;
    s.threads = 1;
    s.engine = engine;
    return s;
}

bool same_bits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }

struct Model {
    Mode mode;
    const char* mistakes;
};

class TreeEqualsRender : public ::testing::TestWithParam<Model> {};

TEST_P(TreeEqualsRender, PixelAndRootColourAreTheRenderedPixel) {
    const Scene scene = load_scene_file(kScenes + "/classic.json");
    for (const Engine engine : {Engine::scalar, Engine::packet}) {
        const RenderSettings s = small_settings(GetParam().mode, GetParam().mistakes, engine);
        const RenderedImage image = render_cpu(scene, s);
        const bool gamma = s.trace.mistakes.has(Mistake::double_gamma);
        int checked = 0;
        for (int y = 0; y < s.height; y += 3) {
            for (int x = 0; x < s.width; x += 3) {
                const PixelTrace t = trace_pixel(scene, s, x, y);
                const std::size_t i = 3 * (static_cast<std::size_t>(y) * s.width + x);
                const float want[3] = {image.rgb[i], image.rgb[i + 1], image.rgb[i + 2]};
                const float got[3] = {t.pixel.x, t.pixel.y, t.pixel.z};
                const float root[3] = {t.tree.c.x, t.tree.c.y, t.tree.c.z};
                for (int k = 0; k < 3; ++k) {
                    ASSERT_TRUE(same_bits(got[k], want[k])) << x << "," << y << " channel " << k;
                    if (!gamma) ASSERT_TRUE(same_bits(root[k], want[k])) << x << "," << y;
                }
                ++checked;
            }
        }
        EXPECT_EQ(checked, 27 * 20);
    }
}

INSTANTIATE_TEST_SUITE_P(Models, TreeEqualsRender,
                         ::testing::Values(Model{Mode::paper, ""}, Model{Mode::classic, ""},
                                           Model{Mode::physical, ""},
                                           Model{Mode::classic, "fresnel_constant"},
                                           Model{Mode::classic, "no_inside_flip,half_pixel_offset"},
                                           Model{Mode::paper, "double_gamma"}));

// Pixels of scenes/classic.json at 640x480 (its own size), classic mode, found with
// `rtdemo trace-pixel scenes/classic.json --pixels ... --mode classic`: (0, 0) is sky,
// (160, 380) lit ground, (0, 479) ground in the silver sphere's shadow, (320, 240) the
// glass sphere's centre, (500, 270) the gold mirror.
TEST(PathBits, KnownPixelsOfClassic) {
    const Scene scene = load_scene_file(kScenes + "/classic.json");
    RenderSettings s = small_settings(Mode::classic, "", Engine::scalar);
    s.width = 640;
    s.height = 480;
    EXPECT_EQ(trace_pixel(scene, s, 0, 0).path, kCameraMiss);
    EXPECT_EQ(trace_pixel(scene, s, 160, 380).path, kDiffuseLit);
    const PixelTrace shadow = trace_pixel(scene, s, 0, 479);
    EXPECT_EQ(shadow.path, kDiffuseShadow);
    EXPECT_EQ(shadow.tree.shadows.at(0).blockers.at(0), 4);  // silver
    const int glass = trace_pixel(scene, s, 320, 240).path;
    const int want = kGlassHit | kGlassEnter | kGlassLeave | kMirror;
    EXPECT_EQ(glass & want, want);
    EXPECT_EQ(glass & (kCameraMiss | kMirrorHit | kDiffuseShadow), 0);
    const int mirror = trace_pixel(scene, s, 500, 270).path;  // the gold sphere
    EXPECT_TRUE(mirror & kMirrorHit);
    EXPECT_FALSE(mirror & kGlassHit);
}

// The ground in the glass sphere's shadow: some ground pixels' shadow ray passes the glass
// (SHADOW_GLASS, and the first blocker recorded is the glass), and their colour is darker
// than a lit ground pixel's.
TEST(PathBits, GroundInTheGlassShadow) {
    const Scene scene = load_scene_file(kScenes + "/classic.json");
    const RenderSettings s = small_settings(Mode::classic, "", Engine::scalar);
    const PixelTrace lit = trace_pixel(scene, s, 20, 47);  // (160, 380) at 640x480
    ASSERT_EQ(lit.path, kDiffuseLit);
    int shadowed = 0;
    for (int y = 0; y < s.height; ++y) {
        for (int x = 0; x < s.width; ++x) {
            const PixelTrace t = trace_pixel(scene, s, x, y);
            if (t.tree.sphere != 0 || !(t.path & kShadowGlass)) continue;
            ++shadowed;
            EXPECT_EQ(t.tree.shadows.at(0).blockers.at(0), 1);
            EXPECT_LT(t.pixel.x, lit.pixel.x);
            EXPECT_FALSE(t.path & kDiffuseLit);
        }
    }
    EXPECT_GT(shadowed, 10);
}

// The path AOV's plane holds, for every pixel, the bits of that pixel's own traced tree.
TEST(PathPlane, EveryPixelIsItsTreesBits) {
    const Scene scene = load_scene_file(kScenes + "/classic.json");
    RenderSettings s = small_settings(Mode::classic, "", Engine::scalar);
    s.threads = 2;
    const Plane plane = path_plane(scene, s);
    ASSERT_EQ(plane.size(), static_cast<std::size_t>(s.width * s.height));
    for (int y = 0; y < s.height; ++y)
        for (int x = 0; x < s.width; ++x)
            ASSERT_EQ(plane[static_cast<std::size_t>(y * s.width + x)],
                      static_cast<float>(trace_pixel(scene, s, x, y).path))
                << x << "," << y;
}

}  // namespace
}  // namespace rt
