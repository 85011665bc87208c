#include "cli/help_text.h"

#include <cstdio>
#include <sstream>
#include <string>

#include "core/mistakes.h"

namespace rt {
namespace {

const char* kTopHelp = R"(rtdemo - the course paper's Whitted ray tracer (CPU and GLSL)

usage:
  rtdemo render SCENE.json -o OUT.exr [options]   render a scene (rtdemo render --help)
  rtdemo view SCENE.json [options]                ray-trace it live in a window (rtdemo view --help)
  rtdemo trace-pixel SCENE.json X Y [options]     one pixel's ray tree as JSON (trace-pixel --help)
  rtdemo --help | --version

Exit codes: 0 ok, 1 out of memory ("rtdemo: error: out of memory ...") or another failure
the message names, 2 bad arguments (an image over 16384 a side or 64 Mpixels among them),
3 invalid scene file, 4 output not writable, 5 no OpenGL context, shader failure, or
rtdemo-gl (the GL build beside rtdemo) missing, 6 render stopped by its --ray-budget.
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
                         counts (camera, secondary, shadow) in the header. The name picks
                         the format: .exr (or no suffix) this EXR, .png as --png, .ppm as
                         --ppm; any other suffix is refused
  --png OUT.png          8-bit, clamped to [0,1], sRGB-encoded (for people)
  --ppm OUT.ppm          8-bit binary P6, linear, clamped: the paper's own output
  --ppm-rounding R       truncate (default: byte = (unsigned char)(min(1, x) * 255), as the
                         paper's program family writes it) or round (nearest level); both
                         clamp to [0,1] first and write NaN as 0
  --exr-compression C    none (default: fastest, ~10 MB at 640x480), rle or zip (~4 MB)
  --exr-channels C       all (default) or rgb: R, G, B alone, no AOVs (3.7 MB at 640x480;
                         what rtval diagnose renders its candidates with)
                         all+path or rgb+path: also "path", each pixel's path-class bits
                         (docs/diagnosis.md; a second pass of the scalar tracer)
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
  --mistake NAME,...     add named common mistakes (listed below; every backend and
                         engine), as rtval diagnose renders them (docs/paper-model.md)
  --spp N                samples per pixel, a perfect square (1, 4, 9, 16, ...): stratum
                         centres of a sqrt(N) x sqrt(N) grid, box filter. N > 1 needs Q10
                         fixed (physical mode or --fix Q10). Default 1 (pixel centre).
  --max-depth N          recursion limit, 0-64 (default: the scene's max_depth)
  --fresnel-mix A        the paper's Fresnel curve (Q8) A + (1 - A) (1 - cos)^P with
  --fresnel-power P      other constants: A from 0 to 1 (default 0.1), P an integer
                         from 0 to 16 (default 3)
  --camera-map SU,OU,SV,OV
                         another camera: the ray through pixel (px, py) is forward +
                         right u + up v with u = SU (2 px / W - 1) + OU and
                         v = SV (1 - 2 py / H) + OV (the scene's: SU = tan(fov/2) W/H,
                         SV = tan(fov/2), OU = OV = 0)
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
  --width W, --height H  override the camera's size, 1-16384 each (at most 64 Mpixels, e.g.
                         8192x8192: exit 2 past that). A frame kept in memory takes about 32
                         bytes a pixel (2 GiB at 64 Mpixels; 16 without the EXR's AOVs), a
                         streamed output almost none; out of memory is exit 1 with "rtdemo:
                         error: out of memory for an image of WxH pixels ..."
  --threads N            CPU worker threads, tracing and compressing the EXR (default: all
                         cores)
  --engine packet|scalar cpu: rays in SIMD lanes (default; AVX-512, AVX2 or one lane, as the
                         CPU allows; RTDEMO_ISA=scalar|avx2|avx512 forces one) or the
                         one-ray-at-a-time reference tracer; both give the same image
                         (--mistake runs included)
  --backend cpu|gl       the CPU tracer (default) or the GLSL tracer in a headless EGL
                         context (any GPU driver, or Mesa llvmpipe); same EXR layout
  --frames N             render N frames and time them (default 1); cpu: the header's
                         render_seconds is the fastest frame (tracing alone, for benchmarks);
                         gl: the header keeps compile time and median frame time apart
  --ray-budget N         stop the render once it has traced more than N rays (camera,
                         secondary and shadow rays, as the EXR header's rtval.rays_* count
                         them; the workers check every 65536 rays, so it stops within a few
                         milliseconds): no output is written, stderr says "rtdemo: ray budget
                         of N rays exhausted after M rays ...", exit 6. CPU tracer only;
                         default: no limit
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

}  // namespace

void print_top_help(std::FILE* to) { std::fputs(kTopHelp, to); }

void print_render_help() {
    std::fputs(kRenderHelp, stdout);
    print_mistakes();
}

void print_view_help() { std::fputs(kViewHelp, stdout); }

}  // namespace rt
