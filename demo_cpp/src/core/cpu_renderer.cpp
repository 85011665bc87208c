#include "core/cpu_renderer.h"

#include <atomic>
#include <cmath>
#include <optional>
#include <vector>

#include "core/camera_rays.h"
#include "core/mistake_settings.h"
#include "core/student_slips.h"
#include "core/worker_threads.h"
#include "packet/packet_engine.h"

namespace rt {

int strata_per_axis(int spp) {
    if (spp < 1) return 0;
    const int k = static_cast<int>(std::lround(std::sqrt(static_cast<double>(spp))));
    return k * k == spp ? k : 0;
}

bool renders_in_bands(const RenderSettings& settings) { return settings.engine == Engine::packet; }

void render_cpu(const Scene& scene, const RenderSettings& settings, BandSink& sink,
                RayCounts* rays) {
    const PlainRender plain = without_setting_mistakes(scene, settings);
    render_packet(plain.scene, plain.settings, isa_from_environment(), sink, rays);
}

void render_cpu(const Scene& scene, const RenderSettings& settings, RenderedImage& image,
                RayCounts* rays) {
    if (renders_in_bands(settings)) {
        const PlainRender plain = without_setting_mistakes(scene, settings);
        render_packet(plain.scene, plain.settings, isa_from_environment(), image, rays);
    } else {
        image = render_cpu(scene, settings, rays);
    }
}

RenderedImage render_cpu(const Scene& scene, const RenderSettings& settings, RayCounts* rays) {
    if (renders_in_bands(settings)) {
        const PlainRender plain = without_setting_mistakes(scene, settings);
        return render_packet(plain.scene, plain.settings, isa_from_environment(), rays);
    }
    RenderedImage image(settings.width, settings.height);
    const CameraRays shared_camera(scene.camera, settings.width, settings.height,
                                   camera_slips(settings.trace));
    Tracer shared_tracer(scene, settings.trace);
    std::optional<RayBudget> budget;
    if (settings.ray_budget > 0) shared_tracer.set_budget(&budget.emplace(settings.ray_budget));
    const int k = strata_per_axis(settings.spp);
    const float inv_samples = 1.0f / static_cast<float>(k * k);
    const float centre = settings.trace.mistakes.has(Mistake::half_pixel_offset) ? 0.0f : 0.5f;

    // The row counter on a cache line of its own, and each worker with private copies of what
    // it reads per ray: shared read data next to another thread's stack writes cost 70 % more
    // CPU time on two threads (false sharing, measured with perf).
    alignas(64) std::atomic<int> next_row{0};
    std::vector<RayCounts> counts(static_cast<std::size_t>(settings.threads));
    auto worker = [&](int thread) {
        const CameraRays camera = shared_camera;
        const Tracer tracer = shared_tracer;
        const int width = settings.width, height = settings.height;
        for (int y = next_row++; y < height && !tracer.out_of_budget(); y = next_row++) {
            for (int x = 0; x < width; ++x) {
                const std::size_t i = static_cast<std::size_t>(y) * width + x;
                // One sample: it is the centre ray, whose hit gives the AOVs as it is traced.
                PrimaryHit hit;
                color sum(0.0f);
                if (k == 1) {
                    sum = tracer.trace(camera.render_from_camera(x + centre, y + centre), 0, &hit);
                } else {
                    hit = tracer.primary(camera.render_from_camera(x + centre, y + centre));
                    for (int sy = 0; sy < k; ++sy)
                        for (int sx = 0; sx < k; ++sx)
                            sum += tracer.trace(camera.render_from_camera(x + (sx + centre) / k,
                                                                          y + (sy + centre) / k),
                                                0);
                }
                image.id[i] = static_cast<float>(hit.id);
                image.depth[i] = hit.depth;
                image.normal[3 * i + 0] = hit.normal.x;
                image.normal[3 * i + 1] = hit.normal.y;
                image.normal[3 * i + 2] = hit.normal.z;

                color c = sum * inv_samples;
                if (settings.trace.mistakes.has(Mistake::double_gamma))
                    c = {std::pow(c.x, 1 / 2.2f), std::pow(c.y, 1 / 2.2f), std::pow(c.z, 1 / 2.2f)};
                image.rgb[3 * i + 0] = c.x;
                image.rgb[3 * i + 1] = c.y;
                image.rgb[3 * i + 2] = c.z;
            }
        }
        tracer.out_of_budget(true);
        counts[static_cast<std::size_t>(thread)] = tracer.ray_counts();
    };
    run_workers(settings.threads, worker);
    if (budget) budget->check();
    if (rays) {
        *rays = {};
        for (const RayCounts& c : counts) *rays += c;
    }
    return image;
}

}  // namespace rt
