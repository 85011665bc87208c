// rtdemo trace-pixel: the model's ray tree for one pixel (or a list of pixels) as JSON.
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "cli/commands.h"
#include "cli/ray_tree_json.h"
#include "cli/render_args.h"
#include "io/scene_loader.h"

namespace rt {
namespace {

using json = nlohmann::ordered_json;

struct TraceArgs {
    std::vector<std::pair<int, int>> pixels;
    std::string pixels_file;  // --pixels: one output object holding every pixel
    RenderArgs render;
};

// "X Y" lines of `path` (blank lines and lines starting with # skipped).
std::vector<std::pair<int, int>> read_pixel_list(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw UsageError(path + ": --pixels: cannot read the file");
    std::vector<std::pair<int, int>> out;
    std::string line;
    for (int number = 1; std::getline(in, line); ++number) {
        std::istringstream words(line);
        std::string x, y, extra;
        if (!(words >> x) || x[0] == '#') continue;
        if (!(words >> y) || (words >> extra))
            throw UsageError(path + ":" + std::to_string(number) + ": expected 'X Y'");
        const std::string where = path + ":" + std::to_string(number);
        out.emplace_back(parse_int_arg(where, x, 0, kMaxSide),
                         parse_int_arg(where, y, 0, kMaxSide));
    }
    if (out.empty()) throw UsageError(path + ": --pixels: no 'X Y' line in the file");
    return out;
}

// SCENE X Y [options] or SCENE --pixels FILE [options]; --json is accepted (the only format).
TraceArgs parse_trace_args(const std::vector<std::string>& args) {
    TraceArgs out;
    std::vector<std::string> rest;
    for (std::size_t i = 0; i < args.size(); ++i) {
        if (args[i] == "--json") continue;
        if (args[i] == "--pixels") {
            if (i + 1 >= args.size()) throw UsageError("--pixels: expected a value");
            out.pixels_file = args[++i];
        } else {
            rest.push_back(args[i]);
        }
    }
    if (out.pixels_file.empty()) {
        if (rest.size() < 3 || rest[1].rfind('-', 0) == 0 || rest[2].rfind('-', 0) == 0)
            throw UsageError("expected SCENE X Y (or SCENE --pixels FILE; see --help)");
        out.pixels.emplace_back(parse_int_arg("X", rest[1], 0, kMaxSide),
                                parse_int_arg("Y", rest[2], 0, kMaxSide));
        rest.erase(rest.begin() + 1, rest.begin() + 3);
    } else {
        out.pixels = read_pixel_list(out.pixels_file);
    }
    out.render = parse_render_args(rest, false);
    const RenderArgs& r = out.render;
    if (!r.exr.empty() || !r.png.empty() || !r.ppm.empty())
        throw UsageError("trace-pixel writes no image (no -o, --png or --ppm)");
    if (r.gl) throw UsageError("trace-pixel traces with the CPU tracer (no --backend gl)");
    if (r.spp != 1) throw UsageError("--spp: trace-pixel traces the pixel centre only (spp 1)");
    return out;
}

// "Q1,Q5" or "none" (QuirkSet::present_list, MistakeSet::list) as a JSON list.
json name_list(const std::string& text) {
    json out = json::array();
    if (text == "none") return out;
    std::istringstream names(text);
    for (std::string name; std::getline(names, name, ',');) out.push_back(name);
    return out;
}

json header(const TraceArgs& a, const RenderSettings& settings) {
    return {{"format", "rtdemo-ray-tree/1"},
            {"scene", a.render.scene_path},
            {"mode", mode_name(a.render.mode)},
            {"quirks", name_list(settings.trace.quirks.present_list())},
            {"mistakes", name_list(settings.trace.mistakes.list())},
            {"width", settings.width},
            {"height", settings.height}};
}

const char* kHelp = R"(usage: rtdemo trace-pixel SCENE.json X Y [options] [--json]
       rtdemo trace-pixel SCENE.json --pixels FILE [options] [--json]

Prints the model's Whitted ray tree for pixel (X, Y) (0-based, y down) as one JSON object
(format "rtdemo-ray-tree/1", docs/commands/trace-pixel.md): every ray's origin, direction,
the sphere it hits (point, normal, inside), the event there, the Fresnel weight, the shadow
rays with what blocks them, the colour each ray returns, and the pixel's path-class bits.
The pixel is traced as `rtdemo render` traces it at spp 1 (its centre ray, the scalar
tracer): "color" is the value render writes for it, bit for bit.

options:
  --pixels FILE       many pixels in one call: FILE holds "X Y" lines (# comments); the
                      output is one object with the header fields and a "pixels" list
  --json              the output format (the only one; accepted for clarity)
  --mode, --fix, --quirk, --mistake, --max-depth, --fresnel-mix, --fresnel-power,
  --camera-map, --width, --height, --no-shadows, --no-reflection, --no-refraction
                      the model, as for rtdemo render (see rtdemo render --help)

Exit codes as for render; 2 also for a pixel outside the image.
)";

}  // namespace

void print_trace_pixel_help() { std::fputs(kHelp, stdout); }

int run_trace_pixel(const std::vector<std::string>& args) {
    const TraceArgs a = parse_trace_args(args);
    const Scene scene = load_scene_file(a.render.scene_path);
    const RenderSettings settings = settings_for(a.render, scene);
    for (const auto& [x, y] : a.pixels)
        if (x >= settings.width || y >= settings.height)
            throw UsageError("pixel (" + std::to_string(x) + ", " + std::to_string(y) +
                             ") is outside the " + std::to_string(settings.width) + "x" +
                             std::to_string(settings.height) + " image");
    json out = header(a, settings);
    if (a.pixels_file.empty()) {
        const auto [x, y] = a.pixels.front();
        out.update(pixel_json(trace_pixel(scene, settings, x, y), scene, x, y));
    } else {
        json list = json::array();
        for (const auto& [x, y] : a.pixels)
            list.push_back(pixel_json(trace_pixel(scene, settings, x, y), scene, x, y));
        out["pixels"] = std::move(list);
    }
    std::puts(out.dump().c_str());
    return 0;
}

}  // namespace rt
