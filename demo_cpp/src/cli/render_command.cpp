// rtdemo render: check the command line, render on the chosen backend, write the outputs,
// print the summary line.
#include <algorithm>
#include <chrono>
#include <cstdarg>
#include <cstdio>
#include <map>
#include <memory>
#include <new>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>

#include "cli/commands.h"
#include "cli/render_args.h"
#include "core/pixel_trace.h"
#include "gl/gl_backend.h"
#include "io/scene_loader.h"
#include "io/streamed_outputs.h"

namespace rt {
namespace {

// What one render left for the outputs and the summary line.
struct Rendered {
    RenderedImage image;  // the frame; empty when it went to a stream
    double seconds = 0;   // the frame's time (header and summary line)
    RayCounts rays;       // CPU only
    std::optional<GlTiming> gl;
    // The one output written band by band during the frame, if any (streams_output).
    std::unique_ptr<PpmStream> ppm_stream;
    std::unique_ptr<ExrStream> exr_stream;
    double streamed_write = 0;  // the frame's time spent writing bands
    bool streamed() const { return ppm_stream || exr_stream; }
};

double seconds_since(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

std::string format_seconds(double s) {
    std::ostringstream o;
    o.precision(4);
    o << s;
    return o.str();
}

// The EXR header's attributes of a CPU or GL render (without the GL timings).
std::map<std::string, std::string> render_attributes(const RenderArgs& a, const Scene& scene,
                                                     const RenderSettings& settings, double seconds,
                                                     const RayCounts& rays) {
    std::string effects;
    if (!a.shadows) effects += "no-shadows ";
    if (!a.reflection) effects += "no-reflection ";
    if (!a.refraction) effects += "no-refraction ";
    std::map<std::string, std::string> attributes = {
        {"rtval.renderer", "rtdemo"},
        {"rtval.backend", a.gl ? "gl" : "cpu"},
        {"rtval.scene", scene.name},
        {"rtval.mode", mode_name(a.mode)},
        {"rtval.quirks", settings.trace.quirks.present_list()},
        {"rtval.mistakes", settings.trace.mistakes.list()},
        {"rtval.spp", std::to_string(settings.spp)},
        {"rtval.max_depth", std::to_string(settings.trace.max_depth)},
        {"rtval.effects_off", effects.empty() ? "none" : effects},
        {"rtval.render_seconds", format_seconds(seconds)},
    };
    if (!settings.trace.fresnel_curve.is_papers()) {
        attributes["rtval.fresnel_mix"] = std::to_string(settings.trace.fresnel_curve.mix);
        attributes["rtval.fresnel_power"] = std::to_string(settings.trace.fresnel_curve.power);
    }
    if (const auto& m = settings.trace.camera_map)
        attributes["rtval.camera_map"] = std::to_string(m->su) + "," + std::to_string(m->ou) + "," +
                                         std::to_string(m->sv) + "," + std::to_string(m->ov);
    if (!a.gl) {
        attributes["rtval.threads"] = std::to_string(settings.threads);
        attributes["rtval.rays_camera"] = std::to_string(rays.camera);
        attributes["rtval.rays_secondary"] = std::to_string(rays.secondary);
        attributes["rtval.rays_shadow"] = std::to_string(rays.shadow);
    }
    return attributes;
}

void add_gl_attributes(const GlTiming& gl, std::map<std::string, std::string>& attributes) {
    attributes["rtval.gl_renderer"] = gl.renderer;
    attributes["rtval.gl_context_seconds"] = format_seconds(gl.context_seconds);
    attributes["rtval.gl_compile_seconds"] = format_seconds(gl.compile_seconds);
    attributes["rtval.gl_first_frame_seconds"] = format_seconds(gl.first_frame_seconds);
    attributes["rtval.gl_frames"] = std::to_string(gl.frames);
}

// One CPU frame with one output, a PPM or an uncompressed EXR: written band by band while it
// renders (streamed_outputs.h).
bool streams_output(const RenderArgs& a, const RenderSettings& settings) {
    if (a.gl || a.keep_frame || a.frames != 1 || !renders_in_bands(settings) || !a.png.empty())
        return false;
    if (!a.exr.empty() && exr_has_path(a.exr_channels)) return false;  // a second pass
    if (!a.ppm.empty()) return a.exr.empty();
    return a.compression == ExrCompression::none;
}

Rendered render_streamed(const RenderArgs& a, const Scene& scene, const RenderSettings& settings) {
    Rendered r;
    BandSink* sink = nullptr;
    if (!a.ppm.empty()) {
        r.ppm_stream =
            std::make_unique<PpmStream>(a.ppm, settings.width, settings.height, a.ppm_rounding);
        sink = r.ppm_stream.get();
    } else {
        r.exr_stream = std::make_unique<ExrStream>(
            a.exr, settings.width, settings.height,
            render_attributes(a, scene, settings, 0.0, RayCounts{}), a.exr_channels);
        sink = r.exr_stream.get();
    }
    const auto start = std::chrono::steady_clock::now();
    render_cpu(scene, settings, *sink, &r.rays);
    const double seconds = seconds_since(start);
    // The frame's time is the tracing's: less the threads' share of writing the bands.
    r.streamed_write =
        (r.ppm_stream ? r.ppm_stream->write_seconds() : r.exr_stream->write_seconds()) /
        settings.threads;
    r.seconds = std::max(0.0, seconds - r.streamed_write);
    return r;
}

// --frames N times the frame; the fastest counts (tracing alone, for benchmarks).
Rendered render_frames_on_cpu(const RenderArgs& a, const Scene& scene,
                              const RenderSettings& settings) {
    Rendered r;
    for (int f = 0; f < a.frames; ++f) {
        const auto start = std::chrono::steady_clock::now();
        if (f == 0)
            r.image = render_cpu(scene, settings, &r.rays);
        else
            render_cpu(scene, settings, r.image, &r.rays);
        const double s = seconds_since(start);
        r.seconds = f == 0 ? s : std::min(r.seconds, s);
    }
    return r;
}

Rendered render_frames_on_gl(const RenderArgs& a, const Scene& scene,
                             const RenderSettings& settings) {
    Rendered r;
    GlTiming gl;
    r.image = render_with_gl(scene, settings, a.frames, &gl);
    r.seconds = gl.frame_seconds;
    r.gl = gl;
    return r;
}

Rendered render(const RenderArgs& a, const Scene& scene, const RenderSettings& settings) {
    if (streams_output(a, settings)) return render_streamed(a, scene, settings);
    Rendered r =
        a.gl ? render_frames_on_gl(a, scene, settings) : render_frames_on_cpu(a, scene, settings);
    // The path AOV: a second pass of the scalar tracer with its recorder (pixel_trace.h).
    if (!a.exr.empty() && exr_has_path(a.exr_channels)) r.image.path = path_plane(scene, settings);
    return r;
}

// Finishes the stream or writes each output; returns the time spent writing.
double write_outputs(const RenderArgs& a, const Scene& scene, const RenderSettings& settings,
                     const Rendered& r) {
    std::map<std::string, std::string> attributes =
        render_attributes(a, scene, settings, r.seconds, r.rays);
    if (r.gl) add_gl_attributes(*r.gl, attributes);
    const auto start = std::chrono::steady_clock::now();
    if (r.exr_stream) {
        r.exr_stream->finish(attributes);
    } else if (r.ppm_stream) {
        r.ppm_stream->finish();
    } else {
        if (!a.exr.empty())
            write_exr(a.exr, r.image, attributes, a.compression, settings.threads, a.exr_channels);
        if (!a.png.empty()) write_png(a.png, r.image);
        if (!a.ppm.empty()) write_ppm(a.ppm, r.image, a.ppm_rounding);
    }
    return r.streamed_write + seconds_since(start);
}

// printf into a string (the summary line goes to stderr in one write).
__attribute__((format(printf, 1, 2))) std::string printf_string(const char* format, ...) {
    std::va_list args, again;
    va_start(args, format);
    va_copy(again, args);
    const int n = std::vsnprintf(nullptr, 0, format, args);
    va_end(args);
    std::string out(static_cast<std::size_t>(std::max(n, 0)) + 1, '\0');
    std::vsnprintf(out.data(), out.size(), format, again);
    va_end(again);
    out.pop_back();
    return out;
}

void print_summary(const RenderArgs& a, const Scene& scene, const RenderSettings& settings,
                   const Rendered& r, double write_seconds) {
    std::string line =
        printf_string("rtdemo: %s %dx%d mode %s (quirks %s) spp %d: ", scene.name.c_str(),
                      settings.width, settings.height, mode_name(a.mode),
                      settings.trace.quirks.present_list().c_str(), settings.spp);
    if (r.gl)
        line += printf_string(
            "gl on %s, compile %.3f s, first frame %.3f s, frame %.4f s (median of %d)\n",
            r.gl->renderer.c_str(), r.gl->compile_seconds, r.gl->first_frame_seconds,
            r.gl->frame_seconds, std::max(r.gl->frames - 1, 1));
    else
        line += printf_string("%.4f s on %d threads, %.2f M rays (%.1f M rays/s), write %.4f s%s\n",
                              r.seconds, settings.threads, r.rays.total() * 1e-6,
                              r.seconds > 0 ? r.rays.total() * 1e-6 / r.seconds : 0.0,
                              write_seconds, r.streamed() ? " (streamed during the frame)" : "");
    std::fputs(line.c_str(), stderr);
}

// A failed allocation while rendering or writing: what the image needs, and the ways out.
std::string out_of_memory(const RenderSettings& settings) {
    return "out of memory for an image of " + std::to_string(settings.width) + "x" +
           std::to_string(settings.height) +
           " pixels: a frame kept in memory takes about 32 bytes a pixel (16 without the EXR's "
           "AOVs); use a smaller --width/--height or one streamed output (rtdemo render --help)";
}

}  // namespace

int run_render(const std::vector<std::string>& args) {
    RenderArgs a = parse_render_args(args);
    check_distinct_outputs(a);  // first: "names the scene file" says more than its suffix
    route_outputs_by_name(a);
    for (const std::string* out : {&a.exr, &a.png, &a.ppm})
        if (!out->empty()) check_writable(*out);
    const Scene scene = load_scene_file(a.scene_path);
    const RenderSettings settings = settings_for(a, scene);
    try {
        const Rendered r = render(a, scene, settings);
        const double write_seconds = write_outputs(a, scene, settings, r);
        if (!a.quiet) print_summary(a, scene, settings, r, write_seconds);
    } catch (const std::bad_alloc&) {
        throw std::runtime_error(out_of_memory(settings));  // exit 1
    }
    return 0;
}

}  // namespace rt
