// The GLSL backend as rtdemo's commands reach it, the same in both programs built from them
// (CMakeLists.txt). rtdemo-gl links gl_backend_gl.cpp: the headless GLSL tracer and the
// viewer. rtdemo carries no OpenGL and links gl_backend_exec.cpp instead, whose functions
// re-execute the same command line as rtdemo-gl, installed beside it. Both throw GlError
// (exit 5) when the backend cannot run.
#pragma once

#include <string>

#include "cli/render_args.h"
#include "gl/gl_headless.h"

namespace rt {

// main's argv, kept for re-executing the command line; it outlives every call below.
void keep_command_line(char** argv);

// render_gl (gl_headless.h): `frames` frames with the GLSL tracer, the last one returned.
RenderedImage render_with_gl(const Scene& scene, const RenderSettings& settings, int frames,
                             GlTiming* timing);

// rtdemo view: loads the scene `args` names and ray-traces it in a window (gl_viewer.h).
void view_with_gl(const RenderArgs& args, int frames, const std::string& screenshot);

}  // namespace rt
