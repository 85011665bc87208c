// The packet engine: the CPU renderer built around rays in SIMD lanes. Camera rays
// of a small tile fill the lanes (8 per AVX2 vector, 16 per AVX-512); each bounce's secondary
// rays are compacted into the next queue; colours are combined bottom-up in the scalar
// tracer's exact order, so the image is the scalar tracer's bit for bit (tested).
#pragma once

#include <string>

#include "core/band_sink.h"
#include "core/cpu_renderer.h"
#include "core/scene.h"
#include "core/tracer.h"
#include "io/image.h"

namespace rt {

namespace packet {
struct Kernels;
}

enum class Isa { scalar, avx2, avx512 };

const char* isa_name(Isa isa);
// Whether this CPU (and its kernel) runs `isa`.
bool supported(Isa isa);
// The kernels compiled for `isa` (packet/packet_data.h); `isa` must be supported.
const packet::Kernels& kernels_for(Isa isa);
// The widest instruction set this CPU runs.
Isa best_isa();
// RTDEMO_ISA=scalar|avx2|avx512 forces a narrower one (tests, benchmarks); unset or empty: best.
// Throws std::invalid_argument naming the variable for an unknown or unsupported value.
Isa isa_from_environment();

// Precondition: settings validated as for render_cpu, no named mistake that is a setting
// (render_cpu turns those into the settings they are, mistake_settings.h), and `isa`
// supported by this CPU.
RenderedImage render_packet(const Scene& scene, const RenderSettings& settings, Isa isa,
                            RayCounts* rays = nullptr);
// The same into `image`, as render_packet returned it for these settings: no new frame.
void render_packet(const Scene& scene, const RenderSettings& settings, Isa isa,
                   RenderedImage& image, RayCounts* rays = nullptr);
// The same frame handed to `sink` band by band as the threads finish them (band_sink.h)
// instead of kept; the same preconditions.
void render_packet(const Scene& scene, const RenderSettings& settings, Isa isa, BandSink& sink,
                   RayCounts* rays = nullptr);

}  // namespace rt
