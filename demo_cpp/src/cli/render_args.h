// rtdemo render's (and view's) command line: its options parsed into RenderArgs, checked, and
// turned into the renderer's settings for a scene.
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "cli/cli_args.h"
#include "core/cpu_renderer.h"
#include "core/mistakes.h"
#include "core/quirks.h"
#include "core/scene.h"
#include "io/image_io.h"

namespace rt {

// The largest image rtdemo renders: 16384 a side, 64 Mpixels in all (8192 x 8192).
constexpr int kMaxSide = 16384;
constexpr long long kMaxPixels = 64ll * 1024 * 1024;
constexpr long long kMaxRayBudget = 1000000000000000000ll;  // 10^18: below 2^63

struct RenderArgs {
    std::string scene_path;
    std::string exr, png, ppm;
    ExrCompression compression = ExrCompression::none;
    ExrChannels exr_channels = ExrChannels::all;
    PpmRounding ppm_rounding = PpmRounding::truncate;
    Mode mode = Mode::paper;
    std::vector<std::pair<Quirk, bool>> quirk_changes;  // (quirk, present) in command order
    MistakeSet mistakes;
    std::optional<int> width, height, max_depth;
    std::optional<float> fresnel_mix;
    std::optional<CameraMap> camera_map;
    std::optional<int> fresnel_power;
    int spp = 1;
    int threads = 0;
    int frames = 1;
    long long ray_budget = 0;  // --ray-budget; 0: none
    bool gl = false;
    Engine engine = Engine::packet;
    bool shadows = true, reflection = true, refraction = true, quiet = false;
    bool keep_frame = false;
};

// Throws UsageError. `view` shares these options but has no file outputs
// (output_required = false).
RenderArgs parse_render_args(const std::vector<std::string>& args, bool output_required = true);

// An output equal to the scene file or to another output is a UsageError: one of the two would
// be lost (exit 2, before anything is rendered).
void check_distinct_outputs(const RenderArgs& a);

// Each output is written in the format its name says. -o picks it by suffix: .exr (or none) an
// EXR, .png a PNG (as --png), .ppm or .pnm a PPM (as --ppm); --png and --ppm refuse a name that
// says another image format. Anything else is a UsageError naming the output and its suffix.
void route_outputs_by_name(RenderArgs& a);

// The settings for rendering `scene` as `a` asks; throws UsageError for a combination that
// cannot be rendered (--mistake or --ray-budget on GL, --spp > 1 with Q10, an image over
// kMaxPixels).
RenderSettings settings_for(const RenderArgs& a, const Scene& scene);

}  // namespace rt
