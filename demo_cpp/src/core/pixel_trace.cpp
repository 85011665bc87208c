#include "core/pixel_trace.h"

#include <atomic>
#include <cmath>

#include "core/camera_rays.h"
#include "core/student_slips.h"
#include "core/worker_threads.h"

namespace rt {
namespace {

// The centre ray of pixel (x, y), where the CPU renderer puts it (cpu_renderer.cpp).
ray centre_ray(const CameraRays& camera, const RenderSettings& settings, int x, int y) {
    const float centre = settings.trace.mistakes.has(Mistake::half_pixel_offset) ? 0.0f : 0.5f;
    return camera.render_from_camera(static_cast<float>(x) + centre,
                                     static_cast<float>(y) + centre);
}

}  // namespace

PixelTrace trace_pixel(const Scene& scene, const RenderSettings& settings, int x, int y) {
    const CameraRays camera(scene.camera, settings.width, settings.height,
                            camera_slips(settings.trace));
    Tracer tracer(scene, settings.trace);
    RayTreeRecorder recorder(scene);
    tracer.set_recorder(&recorder);
    PrimaryHit hit;
    color c = tracer.trace(centre_ray(camera, settings, x, y), 0, &hit) * 1.0f;
    if (settings.trace.mistakes.has(Mistake::double_gamma))
        c = {std::pow(c.x, 1 / 2.2f), std::pow(c.y, 1 / 2.2f), std::pow(c.z, 1 / 2.2f)};
    PixelTrace out;
    out.pixel = c;
    out.tree = recorder.root();
    out.path = path_bits(out.tree, scene);
    return out;
}

Plane path_plane(const Scene& scene, const RenderSettings& settings) {
    const int w = settings.width, h = settings.height;
    Plane plane(static_cast<std::size_t>(w) * h);
    const CameraRays camera(scene.camera, w, h, camera_slips(settings.trace));
    std::atomic<int> next_row{0};
    run_workers(settings.threads, [&](int) {
        Tracer tracer(scene, settings.trace);
        RayTreeRecorder recorder(scene);
        tracer.set_recorder(&recorder);
        for (int y = next_row++; y < h; y = next_row++) {
            for (int x = 0; x < w; ++x) {
                tracer.trace(centre_ray(camera, settings, x, y), 0);
                plane[static_cast<std::size_t>(y) * w + x] =
                    static_cast<float>(path_bits(recorder.root(), scene));
            }
        }
    });
    return plane;
}

}  // namespace rt
