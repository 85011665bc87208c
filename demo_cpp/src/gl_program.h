// The GLSL tracer program: compiles the embedded shaders, uploads the scene as a shader
// storage buffer and draws one full-screen triangle. Needs a current GL 4.3 context.
#pragma once

#include <stdexcept>
#include <string>

#include "scene.h"
#include "tracer.h"

namespace rt {

class GlError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

struct GlView {
    point3 position, look_at;
    vec3 up;
    float fov_y;
};

class TraceProgram {
public:
    // Throws GlError (with the compile/link log) or when the scene exceeds the buffer limit.
    TraceProgram(const Scene& scene, int max_depth);
    ~TraceProgram();
    TraceProgram(const TraceProgram&) = delete;
    TraceProgram& operator=(const TraceProgram&) = delete;

    // Draws into the current framebuffer's viewport of width x height pixels.
    void draw(const TraceOptions& options, const GlView& view, int width, int height, int strata,
              bool display_encode) const;
    double compile_seconds() const { return compile_seconds_; }

private:
    const Scene& scene_;
    int max_depth_;
    unsigned program_ = 0, vao_ = 0, ssbo_ = 0;
    double compile_seconds_ = 0;
};

GlView view_of(const Camera& camera);

}  // namespace rt
