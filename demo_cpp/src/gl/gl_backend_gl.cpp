// The GL backend in rtdemo-gl: the GLSL tracer itself (gl_backend.h).
#include "gl/gl_backend.h"
#include "gl/gl_viewer.h"
#include "io/scene_loader.h"

namespace rt {

void keep_command_line(char**) {}  // nothing to re-execute: this is rtdemo-gl

RenderedImage render_with_gl(const Scene& scene, const RenderSettings& settings, int frames,
                             GlTiming* timing) {
    return render_gl(scene, settings, frames, timing);
}

void view_with_gl(const RenderArgs& args, int frames, const std::string& screenshot) {
    const Scene scene = load_scene_file(args.scene_path);
    const RenderSettings settings = settings_for(args, scene);
    ViewerOptions options;
    options.trace = settings.trace;
    options.width = settings.width;
    options.height = settings.height;
    options.frames = frames;
    options.screenshot = screenshot;
    run_viewer(scene, options);
}

}  // namespace rt
