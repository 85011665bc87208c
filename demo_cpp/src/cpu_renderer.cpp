#include "cpu_renderer.h"

#include <atomic>
#include <cmath>
#include <thread>
#include <vector>

#include "camera_rays.h"

namespace rt {

int strata_per_axis(int spp) {
    if (spp < 1) return 0;
    const int k = static_cast<int>(std::lround(std::sqrt(static_cast<double>(spp))));
    return k * k == spp ? k : 0;
}

RenderedImage render_cpu(const Scene& scene, const RenderSettings& settings) {
    RenderedImage image(settings.width, settings.height);
    const CameraRays camera(scene.camera, settings.width, settings.height);
    const Tracer tracer(scene, settings.trace);
    const int k = strata_per_axis(settings.spp);
    const float inv_samples = 1.0f / static_cast<float>(k * k);

    std::atomic<int> next_row{0};
    auto worker = [&] {
        for (int y = next_row++; y < settings.height; y = next_row++) {
            for (int x = 0; x < settings.width; ++x) {
                const std::size_t i = static_cast<std::size_t>(y) * settings.width + x;
                const PrimaryHit hit =
                    tracer.primary(camera.render_from_camera(x + 0.5f, y + 0.5f));
                image.id[i] = static_cast<float>(hit.id);
                image.depth[i] = hit.depth;
                image.normal[3 * i + 0] = hit.normal.x;
                image.normal[3 * i + 1] = hit.normal.y;
                image.normal[3 * i + 2] = hit.normal.z;

                color sum(0.0f);
                for (int sy = 0; sy < k; ++sy)
                    for (int sx = 0; sx < k; ++sx)
                        sum += tracer.trace(camera.render_from_camera(x + (sx + 0.5f) / k,
                                                                      y + (sy + 0.5f) / k),
                                            0);
                const color c = sum * inv_samples;
                image.rgb[3 * i + 0] = c.x;
                image.rgb[3 * i + 1] = c.y;
                image.rgb[3 * i + 2] = c.z;
            }
        }
    };
    std::vector<std::thread> pool;
    for (int t = 1; t < settings.threads; ++t) pool.emplace_back(worker);
    worker();
    for (auto& t : pool) t.join();
    return image;
}

}  // namespace rt
