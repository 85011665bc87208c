// The GLSL tracer program: compiles the embedded shaders specialised to the scene and the
// trace options (quirks, effects, max depth as constants; a small scene's spheres as
// constants, a large one's in a shader storage buffer) and draws one full-screen triangle.
// Needs a current GL 4.3 context.
#pragma once

#include <map>
#include <stdexcept>
#include <string>

#include "core/scene.h"
#include "core/tracer.h"

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
    // Compiles the program for `options` at once (the others on first use). Throws GlError
    // (with the compile/link log) or when the scene exceeds the storage-buffer limit.
    TraceProgram(const Scene& scene, const TraceOptions& options);
    ~TraceProgram();
    TraceProgram(const TraceProgram&) = delete;
    TraceProgram& operator=(const TraceProgram&) = delete;

    // Draws into the current framebuffer's viewport of width x height pixels; compiles the
    // variant for `options` if this is its first use.
    void draw(const TraceOptions& options, const GlView& view, int width, int height, int strata,
              bool display_encode);
    // Wall time of the first compile and link (llvmpipe defers code generation to the first
    // draw, which the caller times as its first frame).
    double compile_seconds() const { return compile_seconds_; }

    // Spheres up to this count become shader constants; more go to a storage buffer.
    static constexpr std::size_t kMaxConstantSpheres = 32;

private:
    unsigned program_for(const TraceOptions& options);

    const Scene& scene_;
    std::map<std::string, unsigned> programs_;  // by specialisation header
    unsigned vao_ = 0, ssbo_ = 0;
    double compile_seconds_ = 0;
};

GlView view_of(const Camera& camera);

}  // namespace rt
