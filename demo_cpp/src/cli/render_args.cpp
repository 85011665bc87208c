#include "cli/render_args.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <iterator>
#include <map>
#include <thread>

#include "io/file_kind.h"

namespace rt {
namespace {

constexpr float kMaxCameraMap = 1000.0f;

// An option that takes a value: stores it in `out`, given the option as typed (for messages).
using ValuedOption = void (*)(RenderArgs& out, const std::string& option, const std::string& value);
// An option without a value.
using FlagOption = void (*)(RenderArgs& out);

Engine parse_engine(const std::string& text) {
    if (text == "packet") return Engine::packet;
    if (text == "scalar") return Engine::scalar;
    throw std::invalid_argument("expected packet or scalar, got '" + text + "'");
}

// "SU,OU,SV,OV": four finite numbers, each within +-kMaxCameraMap.
CameraMap parse_camera_map(const std::string& text) {
    const std::string rule = "four numbers SU,OU,SV,OV from -1000 to 1000";
    float v[4];
    std::size_t start = 0;
    for (int i = 0; i < 4; ++i) {
        const std::size_t comma = i < 3 ? text.find(',', start) : text.size();
        if (comma == std::string::npos)
            throw std::invalid_argument("expected " + rule + ", got '" + text + "'");
        const std::string part = text.substr(start, comma - start);
        std::size_t used = 0;
        try {
            v[i] = std::stof(part, &used);
        } catch (const std::exception&) {
            used = 0;
        }
        if (part.empty() || used != part.size() || !std::isfinite(v[i]) ||
            std::fabs(v[i]) > kMaxCameraMap)
            throw std::invalid_argument("expected " + rule + ", got '" + text + "'");
        start = comma + 1;
    }
    return {v[0], v[1], v[2], v[3]};
}

bool parse_backend_is_gl(const std::string& text) {
    if (text != "cpu" && text != "gl")
        throw std::invalid_argument("expected cpu or gl, got '" + text + "'");
    return text == "gl";
}

// --fix (present = false) and --quirk (present = true), applied in command order.
void add_quirk_changes(RenderArgs& out, const std::string& option, const std::string& text,
                       bool present) {
    for (Quirk q : parse_option(option, text, parse_quirk_list))
        out.quirk_changes.push_back({q, present});
}

const std::map<std::string, ValuedOption>& valued_options() {
    using S = const std::string&;
    static const std::map<std::string, ValuedOption> table = {
        {"-o", [](RenderArgs& r, S, S v) { r.exr = v; }},
        {"--output", [](RenderArgs& r, S, S v) { r.exr = v; }},
        {"--png", [](RenderArgs& r, S, S v) { r.png = v; }},
        {"--ppm", [](RenderArgs& r, S, S v) { r.ppm = v; }},
        {"--exr-compression",
         [](RenderArgs& r, S o, S v) {
             r.compression = parse_option(o, v, parse_exr_compression);
         }},
        {"--exr-channels",
         [](RenderArgs& r, S o, S v) { r.exr_channels = parse_option(o, v, parse_exr_channels); }},
        {"--ppm-rounding",
         [](RenderArgs& r, S o, S v) { r.ppm_rounding = parse_option(o, v, parse_ppm_rounding); }},
        {"--mode", [](RenderArgs& r, S o, S v) { r.mode = parse_option(o, v, parse_mode); }},
        {"--fix", [](RenderArgs& r, S o, S v) { add_quirk_changes(r, o, v, false); }},
        {"--quirk", [](RenderArgs& r, S o, S v) { add_quirk_changes(r, o, v, true); }},
        {"--mistake",
         [](RenderArgs& r, S o, S v) { r.mistakes = parse_option(o, v, parse_mistake_list); }},
        {"--spp", [](RenderArgs& r, S o, S v) { r.spp = parse_int_arg(o, v, 1, 4096); }},
        {"--max-depth", [](RenderArgs& r, S o, S v) { r.max_depth = parse_int_arg(o, v, 0, 64); }},
        {"--fresnel-mix",
         [](RenderArgs& r, S o, S v) { r.fresnel_mix = parse_float_arg(o, v, 0.0f, 1.0f); }},
        {"--camera-map",
         [](RenderArgs& r, S o, S v) { r.camera_map = parse_option(o, v, parse_camera_map); }},
        {"--fresnel-power",
         [](RenderArgs& r, S o, S v) { r.fresnel_power = parse_int_arg(o, v, 0, 16); }},
        {"--width", [](RenderArgs& r, S o, S v) { r.width = parse_int_arg(o, v, 1, kMaxSide); }},
        {"--height", [](RenderArgs& r, S o, S v) { r.height = parse_int_arg(o, v, 1, kMaxSide); }},
        {"--threads", [](RenderArgs& r, S o, S v) { r.threads = parse_int_arg(o, v, 1, 1024); }},
        {"--backend",
         [](RenderArgs& r, S o, S v) { r.gl = parse_option(o, v, parse_backend_is_gl); }},
        {"--engine", [](RenderArgs& r, S o, S v) { r.engine = parse_option(o, v, parse_engine); }},
        {"--frames", [](RenderArgs& r, S o, S v) { r.frames = parse_int_arg(o, v, 1, 10000); }},
        {"--ray-budget",
         [](RenderArgs& r, S o, S v) { r.ray_budget = parse_long_arg(o, v, 1, kMaxRayBudget); }},
    };
    return table;
}

const std::map<std::string, FlagOption>& flag_options() {
    static const std::map<std::string, FlagOption> table = {
        {"--no-shadows", [](RenderArgs& r) { r.shadows = false; }},
        {"--no-reflection", [](RenderArgs& r) { r.reflection = false; }},
        {"--no-refraction", [](RenderArgs& r) { r.refraction = false; }},
        {"-q", [](RenderArgs& r) { r.quiet = true; }},
        {"--quiet", [](RenderArgs& r) { r.quiet = true; }},
        {"--keep-frame", [](RenderArgs& r) { r.keep_frame = true; }},
    };
    return table;
}

// What no single option can check: a scene, an output where one is needed, a square --spp.
void check_complete(const RenderArgs& out, bool output_required) {
    if (out.scene_path.empty()) throw UsageError("missing SCENE.json (see rtdemo render --help)");
    if (output_required && out.exr.empty() && out.png.empty() && out.ppm.empty())
        throw UsageError("no output: give -o OUT.exr, --png OUT.png or --ppm OUT.ppm");
    if (strata_per_axis(out.spp) == 0)
        throw UsageError("--spp: expected a perfect square (1, 4, 9, 16, ...), got " +
                         std::to_string(out.spp));
}

// The file name's suffix in lower case, with its dot; "" when it has none (".hidden" has none).
std::string lower_suffix(const std::string& path) {
    const std::size_t start =
        path.find_last_of('/') == std::string::npos ? 0 : path.find_last_of('/') + 1;
    const std::size_t dot = path.find_last_of('.');
    if (dot == std::string::npos || dot <= start) return "";
    std::string suffix = path.substr(dot);
    for (char& c : suffix) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return suffix;
}

// The image format a suffix names ("" for a suffix that names none).
std::string format_named_by(const std::string& suffix) {
    static const std::map<std::string, std::string> formats = {
        {".exr", "EXR"}, {".png", "PNG"},  {".ppm", "PPM"},   {".pnm", "PPM"},  {".pfm", "PFM"},
        {".pgm", "PGM"}, {".jpg", "JPEG"}, {".jpeg", "JPEG"}, {".tif", "TIFF"}, {".tiff", "TIFF"},
        {".bmp", "BMP"}, {".hdr", "HDR"},  {".webp", "WebP"}, {".gif", "GIF"}};
    const auto f = formats.find(suffix);
    return f == formats.end() ? "" : f->second;
}

// --png NAME or --ppm NAME whose suffix names another image format: refused, as a PNG named
// x.exr would be read as a broken EXR by whatever opens it next.
void check_named_format(const std::string& option, const std::string& path,
                        const std::string& format) {
    if (path.empty()) return;
    const std::string named = format_named_by(lower_suffix(path));
    if (!named.empty() && named != format)
        throw UsageError(option + " " + path + ": writes a " + format + " but the name says " +
                         named + "; name it ." + (format == "PNG" ? "png" : "ppm") +
                         " (-o picks the format from the name)");
}

// --fresnel-mix and --fresnel-power change the paper's curve, so they need it (Q8); the
// defaults are the paper's 0.1 and 3.
FresnelCurve fresnel_curve_for(const RenderArgs& a, const QuirkSet& quirks) {
    FresnelCurve c;
    if (!a.fresnel_mix && !a.fresnel_power) return c;
    if (!quirks.has(Quirk::paper_fresnel))
        throw UsageError(
            "--fresnel-mix/--fresnel-power change the paper's Fresnel curve (Q8), "
            "which this mode does not use (add --quirk Q8)");
    c.mix = a.fresnel_mix.value_or(c.mix);
    c.power = a.fresnel_power.value_or(c.power);
    return c;
}

}  // namespace

void route_outputs_by_name(RenderArgs& a) {
    check_named_format("--png", a.png, "PNG");
    check_named_format("--ppm", a.ppm, "PPM");
    if (a.exr.empty()) return;
    const std::string suffix = lower_suffix(a.exr);
    if (suffix.empty() || suffix == ".exr") return;
    const std::string format = format_named_by(suffix);
    std::string* target = format == "PNG" ? &a.png : format == "PPM" ? &a.ppm : nullptr;
    if (target == nullptr)
        throw UsageError("-o " + a.exr + ": rtdemo writes EXR (.exr), PNG (.png) or PPM (.ppm)" +
                         (format.empty() ? "" : ", not " + format) +
                         "; name the output with one of these suffixes");
    if (!target->empty())
        throw UsageError("-o " + a.exr + " and " + (format == "PNG" ? "--png " : "--ppm ") +
                         *target + " both ask for a " + format + "; give one");
    *target = a.exr;
    a.exr.clear();
}

RenderArgs parse_render_args(const std::vector<std::string>& args, bool output_required) {
    RenderArgs out;
    for (std::size_t i = 0; i < args.size(); ++i) {
        const std::string& a = args[i];
        if (const auto flag = flag_options().find(a); flag != flag_options().end()) {
            flag->second(out);
        } else if (const auto valued = valued_options().find(a); valued != valued_options().end()) {
            if (i + 1 >= args.size()) throw UsageError(a + ": expected a value");
            valued->second(out, a, args[++i]);
        } else if (!a.empty() && a[0] == '-') {
            throw UsageError("unknown option '" + a + "' (see rtdemo render --help)");
        } else if (out.scene_path.empty()) {
            out.scene_path = a;
        } else {
            throw UsageError("unexpected argument '" + a + "' (one scene file per call)");
        }
    }
    check_complete(out, output_required);
    return out;
}

void check_distinct_outputs(const RenderArgs& a) {
    const std::pair<const char*, const std::string*> outs[] = {
        {"-o", &a.exr}, {"--png", &a.png}, {"--ppm", &a.ppm}};
    for (std::size_t i = 0; i < std::size(outs); ++i) {
        if (outs[i].second->empty()) continue;
        if (same_file(*outs[i].second, a.scene_path))
            throw UsageError(*outs[i].second + ": " + outs[i].first +
                             " names the scene file; refusing to overwrite an input");
        for (std::size_t j = 0; j < i; ++j)
            if (!outs[j].second->empty() && same_file(*outs[i].second, *outs[j].second))
                throw UsageError(*outs[i].second + ": " + outs[i].first + " and " + outs[j].first +
                                 " name the same file");
    }
}

RenderSettings settings_for(const RenderArgs& a, const Scene& scene) {
    RenderSettings settings;
    settings.trace.quirks = quirks_for(a.mode);
    for (const auto& [q, present] : a.quirk_changes) {
        if (present)
            settings.trace.quirks.add(q);
        else
            settings.trace.quirks.fix(q);
    }
    if (a.ray_budget > 0 && a.gl)
        throw UsageError("--ray-budget needs the CPU tracer (--backend cpu)");
    settings.ray_budget = static_cast<std::uint64_t>(a.ray_budget);
    settings.trace.mistakes = a.mistakes;
    if (a.spp > 1 && settings.trace.quirks.has(Quirk::pixel_centre_rays))
        throw UsageError("--spp " + std::to_string(a.spp) +
                         " needs quirk Q10 fixed (use --mode physical or --fix Q10)");
    settings.trace.max_depth = a.max_depth.value_or(scene.max_depth);
    settings.trace.fresnel_curve = fresnel_curve_for(a, settings.trace.quirks);
    settings.trace.camera_map = a.camera_map;
    settings.trace.shadows = a.shadows;
    settings.trace.reflection = a.reflection;
    settings.trace.refraction = a.refraction;
    settings.width = a.width.value_or(scene.camera.width);
    settings.height = a.height.value_or(scene.camera.height);
    if (static_cast<long long>(settings.width) * settings.height > kMaxPixels)
        throw UsageError("image of " + std::to_string(settings.width) + "x" +
                         std::to_string(settings.height) + " pixels is too large (at most " +
                         std::to_string(kMaxPixels) + " pixels)");
    settings.spp = a.spp;
    settings.engine = a.engine;
    settings.aovs = !a.exr.empty() && exr_has_aovs(a.exr_channels);  // only in the EXR
    settings.threads =
        a.threads > 0 ? a.threads : std::max(1u, std::thread::hardware_concurrency());
    return settings;
}

}  // namespace rt
