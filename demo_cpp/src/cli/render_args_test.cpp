#include "cli/render_args.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace rt {
namespace {

std::string usage_error(const std::vector<std::string>& args, bool output_required = true) {
    try {
        parse_render_args(args, output_required);
    } catch (const UsageError& e) {
        return e.what();
    }
    return "(no error)";
}

TEST(RenderArgs, EachOutputAndAlgorithmOptionSetsItsField) {
    const RenderArgs a = parse_render_args({"s.json",
                                            "--output",
                                            "a.exr",
                                            "--png",
                                            "a.png",
                                            "--ppm",
                                            "a.ppm",
                                            "--exr-compression",
                                            "zip",
                                            "--ppm-rounding",
                                            "round",
                                            "--mode",
                                            "classic",
                                            "--fix",
                                            "Q1,Q2",
                                            "--quirk",
                                            "Q2",
                                            "--mistake",
                                            "no_offset",
                                            "--spp",
                                            "4",
                                            "--max-depth",
                                            "0",
                                            "--no-shadows",
                                            "--no-reflection",
                                            "--no-refraction"});
    EXPECT_EQ(a.scene_path, "s.json");
    EXPECT_EQ(a.exr, "a.exr");
    EXPECT_EQ(a.png, "a.png");
    EXPECT_EQ(a.ppm, "a.ppm");
    EXPECT_EQ(a.compression, ExrCompression::zip);
    EXPECT_EQ(a.ppm_rounding, PpmRounding::round);
    EXPECT_EQ(a.mode, Mode::classic);
    const std::vector<std::pair<Quirk, bool>> changes = {{Quirk::paper_intersection, false},
                                                         {Quirk::eta_one_over_ior_leaving, false},
                                                         {Quirk::eta_one_over_ior_leaving, true}};
    EXPECT_EQ(a.quirk_changes, changes);
    EXPECT_EQ(a.mistakes.list(), "no_offset");
    EXPECT_EQ(a.spp, 4);
    EXPECT_EQ(a.max_depth, 0);
    EXPECT_FALSE(a.shadows || a.reflection || a.refraction);
}

TEST(RenderArgs, EachImageAndRunOptionSetsItsField) {
    const RenderArgs a = parse_render_args(
        {"--width", "16384", "--height", "1", "--threads", "3", "--backend", "gl", "--engine",
         "scalar", "--frames", "7", "--quiet", "--keep-frame", "-o", "a.exr", "s.json"});
    EXPECT_EQ(a.scene_path, "s.json");
    EXPECT_EQ(a.width, kMaxSide);
    EXPECT_EQ(a.height, 1);
    EXPECT_EQ(a.threads, 3);
    EXPECT_TRUE(a.gl);
    EXPECT_EQ(a.engine, Engine::scalar);
    EXPECT_EQ(a.frames, 7);
    EXPECT_TRUE(a.quiet && a.keep_frame);
}

TEST(RenderArgs, DefaultsAreThePapersProgramOnTheCpu) {
    const RenderArgs a = parse_render_args({"-o", "a.exr", "s.json"});
    EXPECT_EQ(a.exr, "a.exr");
    EXPECT_EQ(a.mode, Mode::paper);
    EXPECT_EQ(a.spp, 1);
    EXPECT_FALSE(a.gl || a.width || a.height || a.max_depth || a.quiet || a.keep_frame);
    EXPECT_EQ(a.engine, Engine::packet);
}

TEST(RenderArgs, AWrongValueNamesTheOptionAndTheValue) {
    const std::vector<std::string> base = {"s.json", "-o", "a.exr"};
    auto with = [&](const std::string& option, const std::string& value) {
        std::vector<std::string> args = base;
        args.push_back(option);
        args.push_back(value);
        return usage_error(args);
    };
    EXPECT_EQ(with("--mode", "bad"),
              "--mode: unknown mode 'bad' (expected paper, classic or physical)");
    EXPECT_EQ(with("--fix", "Q14"), "--fix: unknown quirk 'Q14' (expected Q1 ... Q13)");
    EXPECT_EQ(with("--quirk", ""), "--quirk: empty quirk list (expected e.g. Q1,Q5)");
    EXPECT_EQ(with("--exr-compression", "lz"),
              "--exr-compression: expected none, rle or zip, got 'lz'");
    EXPECT_EQ(with("--ppm-rounding", "nearest"),
              "--ppm-rounding: expected truncate or round, got 'nearest'");
    EXPECT_EQ(with("--backend", "vulkan"), "--backend: expected cpu or gl, got 'vulkan'");
    EXPECT_EQ(with("--engine", "simd"), "--engine: expected packet or scalar, got 'simd'");
    EXPECT_EQ(with("--width", "16385"),
              "--width: expected an integer from 1 to 16384, got '16385'");
    EXPECT_EQ(with("--spp", "3"), "--spp: expected a perfect square (1, 4, 9, 16, ...), got 3");
    EXPECT_NE(with("--mistake", "no_ofset").find("--mistake: unknown mistake 'no_ofset'"),
              std::string::npos);
    EXPECT_EQ(with("--fresnel-mix", "1.5"),
              "--fresnel-mix: expected a number from 0 to 1, got '1.5'");
    EXPECT_EQ(with("--fresnel-mix", "nan"),
              "--fresnel-mix: expected a number from 0 to 1, got 'nan'");
    EXPECT_EQ(with("--fresnel-mix", "0.5x"),
              "--fresnel-mix: expected a number from 0 to 1, got '0.5x'");
    EXPECT_EQ(with("--fresnel-power", "2.5"),
              "--fresnel-power: expected an integer from 0 to 16, got '2.5'");
    const std::string map_rule =
        "--camera-map: expected four numbers SU,OU,SV,OV from -1000 to 1000";
    EXPECT_EQ(with("--camera-map", "1,0,1"), map_rule + ", got '1,0,1'");
    EXPECT_EQ(with("--camera-map", "1,0,1,nan"), map_rule + ", got '1,0,1,nan'");
    EXPECT_EQ(with("--camera-map", "1,,1,0"), map_rule + ", got '1,,1,0'");
    EXPECT_EQ(with("--camera-map", "1,0,1,0,5"), map_rule + ", got '1,0,1,0,5'");
    EXPECT_EQ(with("--camera-map", "1e9,0,1,0"), map_rule + ", got '1e9,0,1,0'");
    const RenderArgs a = parse_render_args({"s.json", "-o", "a.exr", "--camera-map", "1,-0.5,2,0"});
    ASSERT_TRUE(a.camera_map);
    EXPECT_EQ(a.camera_map->ou, -0.5f);
    EXPECT_EQ(a.camera_map->sv, 2.0f);
}

// The curve's constants change Q8's curve: refused where the mode has none, kept otherwise.
TEST(RenderArgs, FresnelCurveNeedsThePapersCurve) {
    const Scene scene;
    RenderArgs a = parse_render_args({"s.json", "-o", "a.exr", "--fresnel-mix", "0.9"});
    a.mode = Mode::physical;
    EXPECT_THROW(settings_for(a, scene), UsageError);
    a.mode = Mode::classic;
    const RenderSettings s = settings_for(a, scene);
    EXPECT_FLOAT_EQ(s.trace.fresnel_curve.mix, 0.9f);
    EXPECT_EQ(s.trace.fresnel_curve.power, 3);
}

TEST(RenderArgs, MalformedCommandLinesSayWhatIsWrong) {
    EXPECT_EQ(usage_error({"s.json", "-o"}), "-o: expected a value");
    EXPECT_EQ(usage_error({"s.json", "-o", "a.exr", "-"}),
              "unknown option '-' (see rtdemo render --help)");
    EXPECT_EQ(usage_error({"s.json", "-o", "a.exr", "t.json"}),
              "unexpected argument 't.json' (one scene file per call)");
    EXPECT_EQ(usage_error({"-o", "a.exr"}), "missing SCENE.json (see rtdemo render --help)");
    EXPECT_EQ(usage_error({"s.json"}),
              "no output: give -o OUT.exr, --png OUT.png or --ppm OUT.ppm");
    EXPECT_EQ(usage_error({"s.json"}, false), "(no error)");
}

TEST(RenderArgs, SettingsRefuseWhatCannotBeRendered) {
    Scene scene;
    scene.camera.width = 640;
    scene.camera.height = 480;
    auto settings_error = [&](const std::vector<std::string>& args) -> std::string {
        try {
            settings_for(parse_render_args(args), scene);
        } catch (const UsageError& e) {
            return e.what();
        }
        return "(no error)";
    };
    EXPECT_EQ(settings_error({"s.json", "-o", "a.exr", "--width", "8192", "--height", "8192"}),
              "(no error)");
    EXPECT_EQ(settings_error({"s.json", "-o", "a.exr", "--width", "8193", "--height", "8192"}),
              "image of 8193x8192 pixels is too large (at most 67108864 pixels)");
    EXPECT_EQ(settings_error({"s.json", "-o", "a.exr", "--spp", "4"}),
              "--spp 4 needs quirk Q10 fixed (use --mode physical or --fix Q10)");
    // The GLSL shader renders every named mistake (test_gl_backend.py compares it with the CPU).
    EXPECT_EQ(
        settings_error({"s.json", "-o", "a.exr", "--backend", "gl", "--mistake", "no_offset"}),
        "(no error)");
    EXPECT_EQ(settings_error({"s.json", "-o", "a.exr", "--backend", "gl", "--ray-budget", "9"}),
              "--ray-budget needs the CPU tracer (--backend cpu)");
    EXPECT_EQ(settings_for(
                  parse_render_args({"s.json", "-o", "a.exr", "--ray-budget", "5000000000"}), scene)
                  .ray_budget,
              5000000000u);  // past 2^32
    EXPECT_THROW(parse_render_args({"s.json", "-o", "a.exr", "--ray-budget", "0"}), UsageError);
    const RenderSettings s = settings_for(
        parse_render_args({"s.json", "--png", "a.png", "--mode", "physical", "--spp", "9"}), scene);
    EXPECT_EQ(s.width, 640);
    EXPECT_EQ(s.spp, 9);
    EXPECT_FALSE(s.aovs);  // only the EXR carries them
    EXPECT_GE(s.threads, 1);
}

// The outputs after -o is routed by its name, or the UsageError's text.
std::string routed(const std::vector<std::string>& args) {
    try {
        RenderArgs a = parse_render_args(args);
        route_outputs_by_name(a);
        return "exr=" + a.exr + " png=" + a.png + " ppm=" + a.ppm;
    } catch (const UsageError& e) {
        return e.what();
    }
}

TEST(RenderArgs, OutputWritesTheFormatItsNameSays) {
    EXPECT_EQ(routed({"s.json", "-o", "x.png"}), "exr= png=x.png ppm=");
    EXPECT_EQ(routed({"s.json", "-o", "dir.v2/X.PPM"}), "exr= png= ppm=dir.v2/X.PPM");
    EXPECT_EQ(routed({"s.json", "-o", "x.pnm"}), "exr= png= ppm=x.pnm");
    EXPECT_EQ(routed({"s.json", "-o", "x.exr"}), "exr=x.exr png= ppm=");
    EXPECT_EQ(routed({"s.json", "-o", "dir.v2/x"}), "exr=dir.v2/x png= ppm=");
    EXPECT_EQ(routed({"s.json", "--png", "a.png", "--ppm", "b"}), "exr= png=a.png ppm=b");
}

TEST(RenderArgs, OutputNamedForAnotherFormatIsRefused) {
    EXPECT_EQ(routed({"s.json", "-o", "x.jpg"}),
              "-o x.jpg: rtdemo writes EXR (.exr), PNG (.png) or PPM (.ppm), not JPEG; name the "
              "output with one of these suffixes");
    EXPECT_EQ(routed({"s.json", "-o", "x.json"}),
              "-o x.json: rtdemo writes EXR (.exr), PNG (.png) or PPM (.ppm); name the output "
              "with one of these suffixes");
    EXPECT_EQ(routed({"s.json", "-o", "x.png", "--png", "y.png"}),
              "-o x.png and --png y.png both ask for a PNG; give one");
    EXPECT_EQ(routed({"s.json", "--png", "x.exr"}),
              "--png x.exr: writes a PNG but the name says EXR; name it .png (-o picks the "
              "format from the name)");
    EXPECT_EQ(routed({"s.json", "--ppm", "x.png"}),
              "--ppm x.png: writes a PPM but the name says PNG; name it .ppm (-o picks the "
              "format from the name)");
}

}  // namespace
}  // namespace rt
