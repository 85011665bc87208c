#include "gl/gl_program.h"

#include <epoxy/gl.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include "core/light_units.h"
#include "core/mistakes.h"
#include "embedded_shaders.h"

namespace rt {
namespace {

// The info log of a shader or program (getiv/getlog: glGetShaderiv/InfoLog or the Program pair).
template <class GetIv, class GetLog>
std::string info_log(unsigned object, GetIv getiv, GetLog getlog) {
    int length = 0;
    getiv(object, GL_INFO_LOG_LENGTH, &length);
    std::string log(static_cast<std::size_t>(std::max(length, 1)), '\0');
    getlog(object, length, nullptr, log.data());
    return log;
}

unsigned compile(GLenum type, const std::string& source, const char* name) {
    const unsigned shader = glCreateShader(type);
    const char* text = source.c_str();
    glShaderSource(shader, 1, &text, nullptr);
    glCompileShader(shader);
    int ok = 0;
    glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        const std::string log = info_log(shader, glGetShaderiv, glGetShaderInfoLog);
        glDeleteShader(shader);
        throw GlError(std::string("cannot compile ") + name + ":\n" + log);
    }
    return shader;
}

// std430 layout of trace.frag.glsl's Sphere: five vec4.
struct GpuSphere {
    float center_radius[4];
    float color_reflection[4];
    float emission_transparency[4];
    float ior[4];
    float light_intensity[4];
};

std::vector<GpuSphere> gpu_spheres(const Scene& scene) {
    std::vector<GpuSphere> data(std::max<std::size_t>(scene.spheres.size(), 1));
    for (std::size_t i = 0; i < scene.spheres.size(); ++i) {
        const Sphere& s = scene.spheres[i];
        const color intensity = s.is_light() ? point_intensity(scene, s) : color(0.0f);
        data[i] = {{s.center.x, s.center.y, s.center.z, s.radius},
                   {s.surface_color.x, s.surface_color.y, s.surface_color.z, s.reflection},
                   {s.emission.x, s.emission.y, s.emission.z, s.transparency},
                   {s.ior, 0, 0, 0},
                   {intensity.x, intensity.y, intensity.z, s.is_light() ? 1.0f : 0.0f}};
    }
    return data;
}

// A float as a GLSL constant by its bit pattern: exactly the CPU's float, no decimal round
// trip. The scene's values are constants rather than uniforms: on llvmpipe a fragment
// shader reads a uniform lane by lane.
std::string float_constant(float v) {
    std::uint32_t bits;
    std::memcpy(&bits, &v, sizeof bits);
    return "uintBitsToFloat(" + std::to_string(bits) + "u)";
}

// The spheres as a GLSL constructor list.
std::string sphere_constants(const Scene& scene) {
    std::string out;
    auto vec4_of = [](const float(&v)[4]) {
        return "vec4(" + float_constant(v[0]) + "," + float_constant(v[1]) + "," +
               float_constant(v[2]) + "," + float_constant(v[3]) + ")";
    };
    for (const GpuSphere& g : gpu_spheres(scene)) {
        if (!out.empty()) out += ",";
        out += "Sphere(" + vec4_of(g.center_radius) + "," + vec4_of(g.color_reflection) + "," +
               vec4_of(g.emission_transparency) + "," + vec4_of(g.ior) + "," +
               vec4_of(g.light_intensity) + ")";
    }
    return out;
}

// The lights' indices as constants, so that direct light loops over the lights only, not
// over every sphere of the scene (a thousand, read from the storage buffer, in a stress scene).
std::string light_indices(const Scene& scene) {
    std::string list;
    int count = 0;
    for (std::size_t i = 0; i < scene.spheres.size(); ++i) {
        if (!scene.spheres[i].is_light()) continue;
        list += (count++ ? "," : "") + std::to_string(i);
    }
    return "#define LIGHT_COUNT " + std::to_string(count) + "\n#define LIGHT_INDICES " + list +
           "\n";
}

// The named mistakes' bit numbers, M_<name>, for trace.frag.glsl's mistake(M_name): from the
// catalogue, so that the shader names a mistake as mistakes.json does and a renamed or
// removed one fails to compile rather than switching another.
std::string mistake_numbers() {
    static_assert(kMistakeCount <= 64, "MISTAKES_LO and MISTAKES_HI hold 64 bits");
    std::string out;
    for (int m = 0; m < kMistakeCount; ++m)
        out += std::string("#define M_") + mistake_name(static_cast<Mistake>(m)) + " " +
               std::to_string(m) + "\n";
    return out;
}

// The mistakes whose image hangs on the last bit of a ray's origin (a ray starting on the
// surface it leaves, or turned into it): the shader then rounds as the CPU does
// (trace.frag.glsl's EXACT_ARITHMETIC), at some cost, only for them.
bool needs_exact_arithmetic(const MistakeSet& mistakes) {
    return mistakes.has(Mistake::no_offset) || mistakes.has(Mistake::reflect_sign);
}

std::uint64_t mistake_mask(const MistakeSet& mistakes) {
    std::uint64_t mask = 0;
    for (int m = 0; m < kMistakeCount; ++m)
        if (mistakes.has(static_cast<Mistake>(m))) mask |= std::uint64_t{1} << m;
    return mask;
}

// The mask as trace.frag.glsl's two 32-bit halves (GLSL 4.30 has no 64-bit integers).
std::string mistake_defines(const MistakeSet& mistakes) {
    const std::uint64_t mask = mistake_mask(mistakes);
    return "#define MISTAKES_LO " + std::to_string(mask & 0xffffffffu) + "u\n#define MISTAKES_HI " +
           std::to_string(mask >> 32) + "u\n";
}

}  // namespace

GlView view_of(const Camera& c) { return {c.position, c.look_at, c.up, c.fov_y}; }

TraceProgram::TraceProgram(const Scene& scene, const TraceOptions& options) : scene_(scene) {
    const auto start = std::chrono::steady_clock::now();
    if (scene.spheres.size() > kMaxConstantSpheres) {
        GLint64 max_block = 0;
        glGetInteger64v(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &max_block);
        const long long needed = static_cast<long long>(scene.spheres.size()) * sizeof(GpuSphere);
        if (needed > max_block)
            throw GlError("scene has " + std::to_string(scene.spheres.size()) +
                          " spheres; this GL's storage-buffer limit holds " +
                          std::to_string(max_block / sizeof(GpuSphere)));
        const std::vector<GpuSphere> data = gpu_spheres(scene);
        glGenBuffers(1, &ssbo_);
        glBindBuffer(GL_SHADER_STORAGE_BUFFER, ssbo_);
        glBufferData(GL_SHADER_STORAGE_BUFFER,
                     static_cast<GLsizeiptr>(data.size() * sizeof(GpuSphere)), data.data(),
                     GL_STATIC_DRAW);
    }
    glGenVertexArrays(1, &vao_);
    program_for(options);
    compile_seconds_ =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

unsigned TraceProgram::program_for(const TraceOptions& options) {
    int quirks = 0;
    for (int q = 1; q <= kQuirkCount; ++q)
        if (options.quirks.has(static_cast<Quirk>(q))) quirks |= 1 << (q - 1);
    const int effects =
        (options.shadows ? 1 : 0) | (options.reflection ? 2 : 0) | (options.refraction ? 4 : 0);
    std::string header = "#define QUIRKS " + std::to_string(quirks) + "\n#define EFFECTS " +
                         std::to_string(effects) + "\n#define MAX_DEPTH " +
                         std::to_string(options.max_depth) + "\n#define STACK_SIZE " +
                         std::to_string(std::max(options.max_depth, 1)) + "\n" +
                         mistake_defines(options.mistakes);
    if (needs_exact_arithmetic(options.mistakes)) header += "#define EXACT_ARITHMETIC\n";
    header += "#define FRESNEL_MIX " + float_constant(options.fresnel_curve.mix) +
              "\n#define FRESNEL_POWER " + std::to_string(options.fresnel_curve.power) + "\n";
    if (const auto& m = options.camera_map)
        header += "#define CAMERA_MAP vec4(" + float_constant(m->su) + "," + float_constant(m->ou) +
                  "," + float_constant(m->sv) + "," + float_constant(m->ov) + ")\n";
    if (const auto found = programs_.find(header); found != programs_.end()) return found->second;

    const std::string key = header;
    header += "#define SPHERE_COUNT " +
              std::to_string(std::max<std::size_t>(scene_.spheres.size(), 1)) + "\n";
    if (scene_.spheres.size() <= kMaxConstantSpheres)
        header += "#define SCENE_SPHERES " + sphere_constants(scene_) + "\n";
    header += light_indices(scene_) + mistake_numbers();
    header += "#define BIAS " + float_constant(scene_.bias) + "\n#define BACKGROUND vec3(" +
              float_constant(scene_.background.x) + "," + float_constant(scene_.background.y) +
              "," + float_constant(scene_.background.z) + ")\n";
    const unsigned vs = compile(GL_VERTEX_SHADER, kFullscreenVertSource, "fullscreen.vert.glsl");
    const unsigned fs = compile(
        GL_FRAGMENT_SHADER, "#version 430 core\n" + header + kTraceFragSource, "trace.frag.glsl");
    const unsigned program = glCreateProgram();
    glAttachShader(program, vs);
    glAttachShader(program, fs);
    glLinkProgram(program);
    glDeleteShader(vs);
    glDeleteShader(fs);
    int ok = 0;
    glGetProgramiv(program, GL_LINK_STATUS, &ok);
    if (!ok) {
        const std::string log = info_log(program, glGetProgramiv, glGetProgramInfoLog);
        glDeleteProgram(program);
        throw GlError("cannot link the tracer program:\n" + log);
    }
    programs_.emplace(key, program);
    return program;
}

TraceProgram::~TraceProgram() {
    if (vao_) glDeleteVertexArrays(1, &vao_);
    if (ssbo_) glDeleteBuffers(1, &ssbo_);
    for (const auto& [key, program] : programs_) glDeleteProgram(program);
}

void TraceProgram::draw(const TraceOptions& options, const GlView& view, int width, int height,
                        int strata, bool display_encode) {
    const unsigned program = program_for(options);
    const vec3 forward = normalize(view.look_at - view.position);
    const vec3 right = normalize(cross(forward, view.up));
    const vec3 up = cross(right, forward);

    glUseProgram(program);
    auto loc = [&](const char* name) { return glGetUniformLocation(program, name); };
    glUniform3f(loc("u_cam_origin"), view.position.x, view.position.y, view.position.z);
    glUniform3f(loc("u_cam_forward"), forward.x, forward.y, forward.z);
    glUniform3f(loc("u_cam_right"), right.x, right.y, right.z);
    glUniform3f(loc("u_cam_up"), up.x, up.y, up.z);
    // fov_full_angle: tan(fov) where tan(fov / 2) belongs (camera_rays.cpp).
    const float angle = options.mistakes.has(Mistake::fov_full_angle) ? 1.0f : 0.5f;
    glUniform1f(loc("u_half_height"), std::tan(view.fov_y * angle * kPi / 180.0f));
    glUniform2f(loc("u_size"), static_cast<float>(width), static_cast<float>(height));
    glUniform1i(loc("u_strata"), strata);
    glUniform1i(loc("u_display"), display_encode ? 1 : 0);
    if (ssbo_) glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, ssbo_);
    glBindVertexArray(vao_);
    glViewport(0, 0, width, height);
    glDrawArrays(GL_TRIANGLES, 0, 3);
}

}  // namespace rt
