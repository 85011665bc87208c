// `rtdemo view`: the GLSL tracer in a GLFW window, one ray-traced image per frame.
#pragma once

#include <string>

#include "core/scene.h"
#include "core/tracer.h"

namespace rt {

struct ViewerOptions {
    TraceOptions trace;
    int width = 640;
    int height = 480;
    int frames = 0;          // > 0: render this many frames, then exit (automation)
    std::string screenshot;  // with frames: PNG of the last frame
};

// Throws GlError when no window or context can be had.
void run_viewer(const Scene& scene, const ViewerOptions& options);

}  // namespace rt
