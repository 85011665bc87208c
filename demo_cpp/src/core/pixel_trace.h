// One pixel traced as the CPU renderer traces it (spp 1, the pixel's centre ray), with its ray
// tree recorded; and the path-class plane of a whole frame (the `path` AOV).
#pragma once

#include "core/cpu_renderer.h"
#include "core/ray_tree.h"

namespace rt {

struct PixelTrace {
    color pixel;   // the colour render writes for this pixel at spp 1, bit for bit
    int path = 0;  // path_bits(tree)
    RayNode tree;  // the camera ray's tree
};

// Precondition: 0 <= x < settings.width, 0 <= y < settings.height.
PixelTrace trace_pixel(const Scene& scene, const RenderSettings& settings, int x, int y);

// Per pixel (row-major, y down) the path bits of its centre ray's tree, as floats; traced on
// settings.threads threads with the scalar tracer.
Plane path_plane(const Scene& scene, const RenderSettings& settings);

}  // namespace rt
