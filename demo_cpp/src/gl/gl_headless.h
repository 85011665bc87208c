// The GL backend without a window: an EGL context with no display (Mesa llvmpipe here, a
// GPU driver elsewhere), a float32 framebuffer, and the same image layout as the CPU.
#pragma once

#include "core/cpu_renderer.h"
#include "gl/gl_program.h"
#include "io/image.h"

namespace rt {

struct GlTiming {
    double context_seconds = 0;  // EGL display + context
    double compile_seconds = 0;  // shader compile + link + scene upload
    double first_frame_seconds = 0;
    double frame_seconds = 0;  // median of the timed frames after the first
    int frames = 0;
    std::string renderer;  // GL_RENDERER
};

// Renders `frames` times (>= 1) and returns the last image; throws GlError when no
// context can be created or the shaders fail.
RenderedImage render_gl(const Scene& scene, const RenderSettings& settings, int frames,
                        GlTiming* timing);

}  // namespace rt
