// Renders a scene with the CPU tracer on a pool of threads (rows handed out one at a time).
#pragma once

#include "core/band_sink.h"
#include "core/scene.h"
#include "core/tracer.h"
#include "io/image.h"

namespace rt {

// packet: rays in SIMD lanes (packet/packet_engine.h), the default; scalar: one ray at a time
// through Tracer, the reference the packet engine is tested against.
enum class Engine { packet, scalar };

struct RenderSettings {
    TraceOptions trace;
    int width = 640;
    int height = 480;
    int spp = 1;      // a perfect square k*k: stratum centres of a k x k grid, box filter
    int threads = 1;  // >= 1
    Engine engine = Engine::packet;
    // false: the packet engine leaves id, depth and normal empty. A PPM or PNG shows none of
    // them, and filling 6 MB of planes it never writes cost a PPM render ~10 % (bench/NOTES.md).
    bool aovs = true;
    // The packet engine keeps a tile's whole tree of rays until it sums it back up; past this
    // many rays it traces the tile again pixel by pixel (same image, same counts). Tests set it
    // low to take that path on small scenes.
    long packet_tree_cap = 1L << 16;
    // Rays the frame may trace (camera, secondary and shadow, as RayCounts counts them), 0 for
    // no limit: past it the render stops and throws RayBudgetExhausted (core/ray_budget.h).
    std::uint64_t ray_budget = 0;
};

// Precondition: settings were validated (sizes >= 1, spp a perfect square). With `rays`,
// also reports how many rays of each kind were traced. Every render_cpu throws
// RayBudgetExhausted when the frame passes settings.ray_budget (its output is then garbage).
RenderedImage render_cpu(const Scene& scene, const RenderSettings& settings,
                         RayCounts* rays = nullptr);
// The same frame again into `image`, as render_cpu returned it for these settings: the packet
// engine allocates no new frame then (--frames times the frames after the first so: tracing,
// not the kernel zero-filling a new frame's pages).
void render_cpu(const Scene& scene, const RenderSettings& settings, RenderedImage& image,
                RayCounts* rays = nullptr);

// Whether the frame can be rendered into a BandSink: the packet engine (it renders every
// named mistake, mistake_settings.h).
bool renders_in_bands(const RenderSettings& settings);
// The frame handed to `sink` band by band (band_sink.h). Precondition: renders_in_bands.
void render_cpu(const Scene& scene, const RenderSettings& settings, BandSink& sink,
                RayCounts* rays = nullptr);

// k with k*k == spp, or 0 when spp is not a perfect square >= 1.
int strata_per_axis(int spp);

}  // namespace rt
