// rtdemo: the paper's ray tracer as a command-line program.
#include <malloc.h>

#include <algorithm>
#include <chrono>
#include <climits>
#include <csignal>
#include <cstdio>
#include <iostream>
#include <iterator>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "cli_args.h"
#include "cpu_renderer.h"
#include "file_kind.h"
#ifdef RTDEMO_WITH_GL
#include "gl_headless.h"
#include "gl_viewer.h"
#else
#include <unistd.h>

#include <cerrno>
#include <cstring>
#endif
#include "image_io.h"
#include "mistakes.h"
#include "quirks.h"
#include "scene_loader.h"
#include "streamed_outputs.h"

namespace {

using namespace rt;

constexpr int kExitUsage = 2;
constexpr int kExitScene = 3;
constexpr int kExitOutput = 4;
constexpr int kExitGl = 5;
constexpr long long kMaxPixels = 64ll * 1024 * 1024;

#ifndef RTDEMO_WITH_GL
// rtdemo carries no OpenGL (CMakeLists.txt says why): the GL backend and the viewer run the
// same command line as rtdemo-gl, installed beside it.
char** g_argv = nullptr;

class GlMissing : public std::runtime_error {
    using std::runtime_error::runtime_error;
};

[[noreturn]] void exec_gl_sibling() {
    std::string self(4096, '\0');
    const ssize_t n = ::readlink("/proc/self/exe", self.data(), self.size() - 1);
    if (n <= 0) throw GlMissing("cannot locate rtdemo-gl: /proc/self/exe unreadable");
    self.resize(static_cast<std::size_t>(n));
    const std::string sibling = self.substr(0, self.rfind('/') + 1) + "rtdemo-gl";
    // A build without GL reached again through this variable was installed as rtdemo-gl:
    // an error, not an endless chain of execs.
    if (std::getenv("RTDEMO_GL_EXEC"))
        throw GlMissing(sibling + " is a build without the GL backend (installed wrongly)");
    ::setenv("RTDEMO_GL_EXEC", "1", 1);
    std::fflush(nullptr);
    ::execv(sibling.c_str(), g_argv);
    throw GlMissing("the GL backend and the viewer are in " + sibling +
                    ", which cannot run: " + std::strerror(errno));
}
#endif

const char* kTopHelp = R"(rtdemo - the course paper's Whitted ray tracer (CPU and GLSL)

usage:
  rtdemo render SCENE.json -o OUT.exr [options]   render a scene (rtdemo render --help)
  rtdemo view SCENE.json [options]                ray-trace it live in a window (rtdemo view --help)
  rtdemo --help | --version

Exit codes: 0 ok, 2 bad arguments, 3 invalid scene file, 4 output not writable,
5 no OpenGL context, shader failure, or rtdemo-gl (the GL build beside rtdemo) missing.
)";

const char* kViewHelp = R"(usage: rtdemo view SCENE.json [options]

Opens a GLFW window and ray-traces SCENE every frame with the GLSL tracer.
Drag with the left button to orbit, scroll to dolly; M cycles paper/classic/physical,
S, R, T toggle shadows, reflection, refraction; P saves a screenshot; Esc or Q quits.
The title shows the frame time.

options:
  --mode MODE, --fix Q1,...   as for render (default paper)
  --max-depth N               recursion limit, 0-64 (default: the scene's)
  --width W, --height H       window size (default: the camera's)
  --frames N                  render N frames, then exit (for automation)
  --screenshot OUT.png        with --frames: save the last frame (display-encoded)
)";

const char* kRenderHelp =
    R"(usage: rtdemo render SCENE.json [-o OUT.exr] [--png OUT.png] [--ppm OUT.ppm] [options]

Renders SCENE.json (format rtval-scene/1) with the paper's algorithm.

outputs (at least one):
  -o, --output OUT.exr   float32 EXR: R,G,B linear and unclamped; AOVs id (sphere index,
                         -1 on a miss), depth (camera-ray distance, 0 on a miss), N.X N.Y N.Z
                         (normal facing the camera); scene, mode, quirks, time and ray
                         counts (camera, secondary, shadow) in the header
  --png OUT.png          8-bit, clamped to [0,1], sRGB-encoded (for people)
  --ppm OUT.ppm          8-bit binary P6, linear, clamped: the paper's own output
  --ppm-rounding R       truncate (default: byte = (unsigned char)(min(1, x) * 255), as the
                         paper's program family writes it) or round (nearest level); both
                         clamp to [0,1] first and write NaN as 0
  --exr-compression C    none (default: fastest, ~10 MB at 640x480), rle or zip (~4 MB)
  With one output, a PPM or an uncompressed EXR, the CPU tracer writes each band of rows to
  the file as soon as it is traced (no frame is kept; --keep-frame turns this off). The
  frame's time (header, summary line) then leaves out the writing: its time on the render
  threads divided by their number. The EXR header holds rtval.padding (spaces) to keep its
  size known before the time and ray counts are.

algorithm:
  --mode MODE            paper (default): the paper's program, quirks Q1-Q13 all present
                         classic: the scratchapixel program it descends from
                                  (= paper with Q2, Q4, Q9, Q11, Q12, Q13 fixed; Q3's NaN
                                  can appear)
                         physical: every quirk fixed (robust intersection, TIR, exact
                                  Fresnel, Lambert albedo/pi, point lights with 1/d^2
                                  calibrated by the exporter's light-units rule, bounded
                                  shadow rays blocked by glass, chains cut at max depth).
                                  Lights are points: no soft shadows (no --light-samples).
  --fix Q1,Q2,...        fix these quirks (Q1 ... Q13) on top of --mode (docs/paper-model.md)
  --quirk Q2,Q5,...      add these quirks on top of --mode (classic --quirk Q2 keeps
                         eta = 1/ior when leaving glass); applied in order with --fix
  --mistake NAME,...     add named common mistakes (listed below; CPU tracer only), as
                         rtval diagnose renders them (docs/paper-model.md)
  --spp N                samples per pixel, a perfect square (1, 4, 9, 16, ...): stratum
                         centres of a sqrt(N) x sqrt(N) grid, box filter. N > 1 needs Q10
                         fixed (physical mode or --fix Q10). Default 1 (pixel centre).
  --max-depth N          recursion limit, 0-64 (default: the scene's max_depth)
  --no-shadows, --no-reflection, --no-refraction
                         switch one effect off (per-effect ablation in the judge)

quirks (all present in paper mode; docs/paper-model.md):
  Q1   the tca < 0 early-out, and secondary rays a fixed bias off the surface
  Q2   eta = 1/ior also when leaving glass
  Q3   no total internal reflection: sqrt(k < 0) makes the refracted ray NaN
  Q4   one shadow factor shared by all lights
  Q5   shadow rays not stopped at the light
  Q6   specular surfaces lit as diffuse ones at max depth
  Q7   no 1/pi and no distance falloff; a light sphere shows its emission
  Q8   the paper's Fresnel curve 0.1 + 0.9 (1 - cos)^3, for mirrors too
  Q9   glass casts partial shadows (1 - transparency)
  Q10  one ray through each pixel centre
  Q11  the directly lit colour starts at 1, each light added to it
  Q12  no Lambert cosine: lights behind the surface count too (their shadow rays are cast)
  Q13  the hit sphere's own emission is not added (a light is shaded like a surface)

image:
  --width W, --height H  override the camera's size, 1-16384 each (at most 64 Mpixels)
  --threads N            CPU worker threads, tracing and compressing the EXR (default: all
                         cores)
  --engine packet|scalar cpu: rays in SIMD lanes (default; AVX-512, AVX2 or one lane, as the
                         CPU allows; RTDEMO_ISA=scalar|avx2|avx512 forces one) or the
                         one-ray-at-a-time reference tracer; both give the same image
                         (a --mistake run always takes the reference tracer)
  --backend cpu|gl       the CPU tracer (default) or the GLSL tracer in a headless EGL
                         context (any GPU driver, or Mesa llvmpipe); same EXR layout
  --frames N             render N frames and time them (default 1); cpu: the header's
                         render_seconds is the fastest frame (tracing alone, for benchmarks);
                         gl: the header keeps compile time and median frame time apart
  --keep-frame           trace the whole frame, then write the outputs (no streaming: the
                         summary's write time is then the writers' alone, for benchmarks)
  -q, --quiet            no summary line on stderr

mistakes (--mistake; the catalogue of compare/judge/mistakes.json):
)";

// The catalogue under --help, each explanation wrapped at 92 columns beside its name.
void print_mistakes() {
    for (const MistakeInfo& info : mistake_catalogue()) {
        std::printf("  %-20s", info.name.c_str());
        std::istringstream words(info.explanation);
        std::string word;
        int column = 22;
        while (words >> word) {
            if (column + 1 + static_cast<int>(word.size()) > 92) {
                std::printf("\n%22s", "");
                column = 22;
            }
            std::printf(" %s", word.c_str());
            column += 1 + static_cast<int>(word.size());
        }
        std::printf("\n");
    }
}

struct RenderArgs {
    std::string scene_path;
    std::string exr, png, ppm;
    ExrCompression compression = ExrCompression::none;
    PpmRounding ppm_rounding = PpmRounding::truncate;
    Mode mode = Mode::paper;
    std::vector<std::pair<Quirk, bool>> quirk_changes;  // (quirk, present) in command order
    MistakeSet mistakes;
    std::optional<int> width, height, max_depth;
    int spp = 1;
    int threads = 0;
    int frames = 1;
    bool gl = false;
    Engine engine = Engine::packet;
    bool shadows = true, reflection = true, refraction = true, quiet = false;
    bool keep_frame = false;
};

// `view` shares these options but has no file outputs (output_required = false).
RenderArgs parse_render_args(const std::vector<std::string>& args, bool output_required = true) {
    RenderArgs out;
    auto value = [&](std::size_t& i) -> const std::string& {
        if (i + 1 >= args.size()) throw UsageError(args[i] + ": expected a value");
        return args[++i];
    };
    for (std::size_t i = 0; i < args.size(); ++i) {
        const std::string& a = args[i];
        if (a == "-o" || a == "--output")
            out.exr = value(i);
        else if (a == "--png")
            out.png = value(i);
        else if (a == "--ppm")
            out.ppm = value(i);
        else if (a == "--exr-compression") {
            try {
                out.compression = parse_exr_compression(value(i));
            } catch (const std::invalid_argument& e) {
                throw UsageError(std::string("--exr-compression: ") + e.what());
            }
        } else if (a == "--ppm-rounding") {
            try {
                out.ppm_rounding = parse_ppm_rounding(value(i));
            } catch (const std::invalid_argument& e) {
                throw UsageError(std::string("--ppm-rounding: ") + e.what());
            }
        } else if (a == "--mode") {
            try {
                out.mode = parse_mode(value(i));
            } catch (const std::invalid_argument& e) {
                throw UsageError(std::string("--mode: ") + e.what());
            }
        } else if (a == "--fix") {
            try {
                for (Quirk q : parse_quirk_list(value(i))) out.quirk_changes.push_back({q, false});
            } catch (const std::invalid_argument& e) {
                throw UsageError(std::string("--fix: ") + e.what());
            }
        } else if (a == "--quirk") {
            try {
                for (Quirk q : parse_quirk_list(value(i))) out.quirk_changes.push_back({q, true});
            } catch (const std::invalid_argument& e) {
                throw UsageError(std::string("--quirk: ") + e.what());
            }
        } else if (a == "--mistake") {
            try {
                out.mistakes = parse_mistake_list(value(i));
            } catch (const std::invalid_argument& e) {
                throw UsageError(std::string("--mistake: ") + e.what());
            }
        } else if (a == "--spp")
            out.spp = parse_int_arg(a, value(i), 1, 4096);
        else if (a == "--max-depth")
            out.max_depth = parse_int_arg(a, value(i), 0, 64);
        else if (a == "--width")
            out.width = parse_int_arg(a, value(i), 1, 16384);
        else if (a == "--height")
            out.height = parse_int_arg(a, value(i), 1, 16384);
        else if (a == "--threads")
            out.threads = parse_int_arg(a, value(i), 1, 1024);
        else if (a == "--no-shadows")
            out.shadows = false;
        else if (a == "--no-reflection")
            out.reflection = false;
        else if (a == "--no-refraction")
            out.refraction = false;
        else if (a == "--backend") {
            const std::string& b = value(i);
            if (b != "cpu" && b != "gl")
                throw UsageError("--backend: expected cpu or gl, got '" + b + "'");
            out.gl = b == "gl";
        } else if (a == "--engine") {
            const std::string& e = value(i);
            if (e != "packet" && e != "scalar")
                throw UsageError("--engine: expected packet or scalar, got '" + e + "'");
            out.engine = e == "packet" ? Engine::packet : Engine::scalar;
        } else if (a == "--frames")
            out.frames = parse_int_arg(a, value(i), 1, 10000);
        else if (a == "-q" || a == "--quiet")
            out.quiet = true;
        else if (a == "--keep-frame")
            out.keep_frame = true;
        else if (!a.empty() && a[0] == '-')
            throw UsageError("unknown option '" + a + "' (see rtdemo render --help)");
        else if (out.scene_path.empty())
            out.scene_path = a;
        else
            throw UsageError("unexpected argument '" + a + "' (one scene file per call)");
    }
    if (out.scene_path.empty()) throw UsageError("missing SCENE.json (see rtdemo render --help)");
    if (output_required && out.exr.empty() && out.png.empty() && out.ppm.empty())
        throw UsageError("no output: give -o OUT.exr, --png OUT.png or --ppm OUT.ppm");
    if (strata_per_axis(out.spp) == 0)
        throw UsageError("--spp: expected a perfect square (1, 4, 9, 16, ...), got " +
                         std::to_string(out.spp));
    return out;
}

std::string format_seconds(double s) {
    std::ostringstream o;
    o.precision(4);
    o << s;
    return o.str();
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
    if (a.mistakes.any() && a.gl)
        throw UsageError("--mistake needs the CPU tracer (--backend cpu)");
    settings.trace.mistakes = a.mistakes;
    if (a.spp > 1 && settings.trace.quirks.has(Quirk::Q10))
        throw UsageError("--spp " + std::to_string(a.spp) +
                         " needs quirk Q10 fixed (use --mode physical or --fix Q10)");
    settings.trace.max_depth = a.max_depth.value_or(scene.max_depth);
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
    settings.aovs = !a.exr.empty();  // only the EXR carries them
    settings.threads =
        a.threads > 0 ? a.threads : std::max(1u, std::thread::hardware_concurrency());
    return settings;
}

// An output equal to the scene file or to another output is a usage error: one of the
// two would be lost (exit 2, before anything is rendered).
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

// The EXR header's attributes of a CPU or GL render (the GL timings are added by the GL build).
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
    if (!a.gl) {
        attributes["rtval.threads"] = std::to_string(settings.threads);
        attributes["rtval.rays_camera"] = std::to_string(rays.camera);
        attributes["rtval.rays_secondary"] = std::to_string(rays.secondary);
        attributes["rtval.rays_shadow"] = std::to_string(rays.shadow);
    }
    return attributes;
}

// One CPU frame with one output, a PPM or an uncompressed EXR: written band by band while it
// renders (streamed_outputs.h).
bool streams_output(const RenderArgs& a, const RenderSettings& settings) {
    if (a.gl || a.keep_frame || a.frames != 1 || !renders_in_bands(settings) || !a.png.empty())
        return false;
    if (!a.ppm.empty()) return a.exr.empty();
    return a.compression == ExrCompression::none;
}

int run_render(const std::vector<std::string>& args) {
    const RenderArgs a = parse_render_args(args);
    check_distinct_outputs(a);
    for (const std::string* out : {&a.exr, &a.png, &a.ppm})
        if (!out->empty()) check_writable(*out);

    const Scene scene = load_scene_file(a.scene_path);
    const RenderSettings settings = settings_for(a, scene);

    RenderedImage image;
    double seconds = 0;
    RayCounts rays;
    std::unique_ptr<PpmStream> ppm_stream;
    std::unique_ptr<ExrStream> exr_stream;
    double streamed_write = 0;  // the frame's time spent writing bands (streamed outputs)
#ifdef RTDEMO_WITH_GL
    GlTiming gl;
    if (a.gl) {
        image = render_gl(scene, settings, a.frames, &gl);
        seconds = gl.frame_seconds;
    }
#else
    if (a.gl) exec_gl_sibling();  // after the checks above: a bad command fails here alike
#endif
    if (streams_output(a, settings)) {
        BandSink* sink = nullptr;
        if (!a.ppm.empty()) {
            ppm_stream =
                std::make_unique<PpmStream>(a.ppm, settings.width, settings.height, a.ppm_rounding);
            sink = ppm_stream.get();
        } else {
            exr_stream = std::make_unique<ExrStream>(
                a.exr, settings.width, settings.height,
                render_attributes(a, scene, settings, 0.0, RayCounts{}));
            sink = exr_stream.get();
        }
        const auto start = std::chrono::steady_clock::now();
        render_cpu(scene, settings, *sink, &rays);
        seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        // The frame's time is the tracing's: less the threads' share of writing the bands.
        streamed_write = (ppm_stream ? ppm_stream->write_seconds() : exr_stream->write_seconds()) /
                         settings.threads;
        seconds = std::max(0.0, seconds - streamed_write);
    } else if (!a.gl) {
        for (int f = 0; f < a.frames; ++f) {
            const auto start = std::chrono::steady_clock::now();
            if (f == 0)
                image = render_cpu(scene, settings, &rays);
            else
                render_cpu(scene, settings, image, &rays);
            const double s =
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
            seconds = f == 0 ? s : std::min(seconds, s);
        }
    }

    std::map<std::string, std::string> attributes =
        render_attributes(a, scene, settings, seconds, rays);
#ifdef RTDEMO_WITH_GL
    if (a.gl) {
        attributes["rtval.gl_renderer"] = gl.renderer;
        attributes["rtval.gl_context_seconds"] = format_seconds(gl.context_seconds);
        attributes["rtval.gl_compile_seconds"] = format_seconds(gl.compile_seconds);
        attributes["rtval.gl_first_frame_seconds"] = format_seconds(gl.first_frame_seconds);
        attributes["rtval.gl_frames"] = std::to_string(gl.frames);
    }
#endif
    const auto write_start = std::chrono::steady_clock::now();
    if (exr_stream) {
        exr_stream->finish(attributes);
    } else if (ppm_stream) {
        ppm_stream->finish();
    } else {
        if (!a.exr.empty()) write_exr(a.exr, image, attributes, a.compression, settings.threads);
        if (!a.png.empty()) write_png(a.png, image);
        if (!a.ppm.empty()) write_ppm(a.ppm, image, a.ppm_rounding);
    }
    const double write_seconds =
        streamed_write +
        std::chrono::duration<double>(std::chrono::steady_clock::now() - write_start).count();
#ifdef RTDEMO_WITH_GL
    if (!a.quiet && a.gl)
        std::fprintf(stderr,
                     "rtdemo: %s %dx%d mode %s (quirks %s) spp %d: gl on %s, compile %.3f s, "
                     "first frame %.3f s, frame %.4f s (median of %d)\n",
                     scene.name.c_str(), settings.width, settings.height, mode_name(a.mode),
                     settings.trace.quirks.present_list().c_str(), settings.spp,
                     gl.renderer.c_str(), gl.compile_seconds, gl.first_frame_seconds,
                     gl.frame_seconds, std::max(gl.frames - 1, 1));
    else
#endif
        if (!a.quiet)
        std::fprintf(stderr,
                     "rtdemo: %s %dx%d mode %s (quirks %s) spp %d: %.4f s on %d threads, "
                     "%.2f M rays (%.1f M rays/s), write %.4f s%s\n",
                     scene.name.c_str(), settings.width, settings.height, mode_name(a.mode),
                     settings.trace.quirks.present_list().c_str(), settings.spp, seconds,
                     settings.threads, rays.total() * 1e-6,
                     seconds > 0 ? rays.total() * 1e-6 / seconds : 0.0, write_seconds,
                     ppm_stream || exr_stream ? " (streamed during the frame)" : "");
    return 0;
}

int run_view(const std::vector<std::string>& args) {
    // Same parser as render; outputs are not allowed, --screenshot takes their place.
    std::vector<std::string> rest;
    std::string screenshot;
    int frames = 0;
    for (std::size_t i = 0; i < args.size(); ++i) {
        if (args[i] == "--screenshot" || args[i] == "--frames") {
            if (i + 1 >= args.size()) throw UsageError(args[i] + ": expected a value");
            if (args[i] == "--screenshot")
                screenshot = args[++i];
            else
                frames = parse_int_arg("--frames", args[++i], 1, 100000);
        } else if (args[i] == "-o" || args[i] == "--output" || args[i] == "--png" ||
                   args[i] == "--ppm" || args[i] == "--ppm-rounding" ||
                   args[i] == "--exr-compression" || args[i] == "--backend" || args[i] == "--spp" ||
                   args[i] == "--mistake" || args[i] == "--engine") {
            throw UsageError(args[i] + " is not an option of view (see rtdemo view --help)");
        } else {
            rest.push_back(args[i]);
        }
    }
    const RenderArgs a = parse_render_args(rest, false);
    if (!screenshot.empty() && frames == 0)
        throw UsageError("--screenshot needs --frames N (press P in the window instead)");
    if (!screenshot.empty()) check_writable(screenshot);
#ifndef RTDEMO_WITH_GL
    exec_gl_sibling();
#else
    const Scene scene = load_scene_file(a.scene_path);
    const RenderSettings settings = settings_for(a, scene);
    ViewerOptions options;
    options.trace = settings.trace;
    options.width = settings.width;
    options.height = settings.height;
    options.frames = frames;
    options.screenshot = screenshot;
    run_viewer(scene, options);
    return 0;
#endif
}

}  // namespace

int main(int argc, char** argv) {
    // A render is a short batch job: blocks under 32 MB that it frees are kept for reuse until
    // the process ends, not handed back to the kernel midway (each unmap or trim is a system
    // call that flushes the address translations of every core the process ran on: 0.2-0.5 ms
    // at the end of a frame, bench/NOTES.md; larger blocks, a frame plane over ~2.8 Mpixels,
    // are still mapped and unmapped on their own); the main heap grows 4 MB at a time. Each worker
    // thread keeps its own arena (malloc's default): with one shared arena the two threads'
    // first allocations woke each other through its lock, and Linux then often ran both on
    // the waker's CPU for milliseconds (perf sched, bench/NOTES.md).
    mallopt(M_MMAP_THRESHOLD, 32 << 20);
    mallopt(M_TRIM_THRESHOLD, INT_MAX);
    mallopt(M_TOP_PAD, 4 << 20);
    // Past a file-size limit a write fails (exit 4, the temporary file removed) instead of
    // the process being killed with its temporary file left behind.
    std::signal(SIGXFSZ, SIG_IGN);
#ifndef RTDEMO_WITH_GL
    g_argv = argv;
#endif
    const std::vector<std::string> args(argv + 1, argv + argc);
    try {
        if (args.empty() || args[0] == "--help" || args[0] == "-h" || args[0] == "help") {
            std::fputs(kTopHelp, args.empty() ? stderr : stdout);
            return args.empty() ? kExitUsage : 0;
        }
        if (args[0] == "--version") {
            std::puts("rtdemo " RTVAL_VERSION);
            return 0;
        }
        const std::vector<std::string> rest(args.begin() + 1, args.end());
        for (const std::string& a : rest)
            if (a == "--help" || a == "-h") {
                if (args[0] == "render") {
                    std::fputs(kRenderHelp, stdout);
                    print_mistakes();
                    return 0;
                }
                if (args[0] == "view") {
                    std::fputs(kViewHelp, stdout);
                    return 0;
                }
            }
        if (args[0] == "render") return run_render(rest);
        if (args[0] == "view") return run_view(rest);
        throw UsageError("unknown command '" + args[0] + "' (see rtdemo --help)");
    } catch (const UsageError& e) {
        std::fprintf(stderr, "rtdemo: error: %s\n", e.what());
        return kExitUsage;
    } catch (const SceneError& e) {
        std::fprintf(stderr, "rtdemo: error: %s\n", e.what());
        return kExitScene;
    } catch (const OutputError& e) {
        std::fprintf(stderr, "rtdemo: error: %s\n", e.what());
        return kExitOutput;
#ifdef RTDEMO_WITH_GL
    } catch (const GlError& e) {
        std::fprintf(stderr, "rtdemo: error: OpenGL: %s\n", e.what());
        return kExitGl;
#else
    } catch (const GlMissing& e) {
        std::fprintf(stderr, "rtdemo: error: OpenGL: %s\n", e.what());
        return kExitGl;
#endif
    } catch (const std::bad_alloc&) {
        std::fprintf(stderr, "rtdemo: error: out of memory\n");
        return 1;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "rtdemo: error: %s\n", e.what());
        return 1;
    }
}
