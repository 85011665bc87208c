#include "gl/gl_headless.h"

#include <epoxy/egl.h>
#include <epoxy/gl.h>

#include <algorithm>
#include <chrono>
#include <vector>

namespace rt {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
}

// An EGL display that needs no window system: a device (NVIDIA, Mesa), then Mesa's
// surfaceless platform, then the default display.
EGLDisplay open_display() {
    if (epoxy_has_egl_extension(EGL_NO_DISPLAY, "EGL_EXT_device_enumeration") &&
        epoxy_has_egl_extension(EGL_NO_DISPLAY, "EGL_EXT_platform_device")) {
        EGLDeviceEXT devices[8];
        EGLint count = 0;
        if (eglQueryDevicesEXT(8, devices, &count)) {
            for (EGLint i = 0; i < count; ++i) {
                EGLDisplay d =
                    eglGetPlatformDisplayEXT(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr);
                EGLint major = 0, minor = 0;
                if (d != EGL_NO_DISPLAY && eglInitialize(d, &major, &minor)) return d;
            }
        }
    }
    if (epoxy_has_egl_extension(EGL_NO_DISPLAY, "EGL_MESA_platform_surfaceless")) {
        EGLDisplay d =
            eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
        EGLint major = 0, minor = 0;
        if (d != EGL_NO_DISPLAY && eglInitialize(d, &major, &minor)) return d;
    }
    EGLDisplay d = eglGetDisplay(EGL_DEFAULT_DISPLAY);
    EGLint major = 0, minor = 0;
    if (d != EGL_NO_DISPLAY && eglInitialize(d, &major, &minor)) return d;
    throw GlError("no EGL display could be opened (no GPU driver and no Mesa EGL found)");
}

class EglContext {
public:
    EglContext() {
        display_ = open_display();
        if (!eglBindAPI(EGL_OPENGL_API)) throw GlError("EGL: desktop OpenGL is not supported");
        // EGL_SURFACE_TYPE defaults to windows, which a device display has none of.
        const EGLint config_attribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_SURFACE_TYPE,
                                         EGL_PBUFFER_BIT, EGL_NONE};
        EGLConfig config;
        EGLint n = 0;
        if (!eglChooseConfig(display_, config_attribs, &config, 1, &n) || n == 0)
            throw GlError("EGL: no OpenGL-capable config");
        const EGLint context_attribs[] = {EGL_CONTEXT_MAJOR_VERSION,
                                          4,
                                          EGL_CONTEXT_MINOR_VERSION,
                                          3,
                                          EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                          EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                          EGL_NONE};
        context_ = eglCreateContext(display_, config, EGL_NO_CONTEXT, context_attribs);
        if (context_ == EGL_NO_CONTEXT)
            throw GlError("EGL: cannot create an OpenGL 4.3 core context");
        if (!eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_))
            throw GlError("EGL: cannot make the context current without a surface");
    }
    ~EglContext() {
        eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        if (context_ != EGL_NO_CONTEXT) eglDestroyContext(display_, context_);
        eglTerminate(display_);
    }

private:
    EGLDisplay display_ = EGL_NO_DISPLAY;
    EGLContext context_ = EGL_NO_CONTEXT;
};

// A float32 framebuffer with colour, AOV and normal attachments.
class FloatTarget {
public:
    FloatTarget(int w, int h) {
        glGenFramebuffers(1, &fbo_);
        glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
        glGenTextures(3, textures_);
        const GLenum attachments[3] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1,
                                       GL_COLOR_ATTACHMENT2};
        for (int i = 0; i < 3; ++i) {
            glBindTexture(GL_TEXTURE_2D, textures_[i]);
            glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA32F, w, h);
            glFramebufferTexture2D(GL_FRAMEBUFFER, attachments[i], GL_TEXTURE_2D, textures_[i], 0);
        }
        glDrawBuffers(3, attachments);
        if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
            throw GlError("cannot create a " + std::to_string(w) + "x" + std::to_string(h) +
                          " float32 framebuffer");
    }
    ~FloatTarget() {
        glDeleteTextures(3, textures_);
        glDeleteFramebuffers(1, &fbo_);
    }
    std::vector<float> read(int attachment, int w, int h) const {
        std::vector<float> out(4u * w * h);
        glReadBuffer(GL_COLOR_ATTACHMENT0 + attachment);
        glPixelStorei(GL_PACK_ALIGNMENT, 4);
        glReadPixels(0, 0, w, h, GL_RGBA, GL_FLOAT, out.data());
        return out;
    }

private:
    unsigned fbo_ = 0;
    unsigned textures_[3] = {0, 0, 0};
};

}  // namespace

RenderedImage render_gl(const Scene& scene, const RenderSettings& settings, int frames,
                        GlTiming* timing) {
    GlTiming t;
    auto start = Clock::now();
    EglContext context;
    t.context_seconds = since(start);
    t.renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));

    const int w = settings.width, h = settings.height;
    TraceProgram program(scene, settings.trace);
    t.compile_seconds = program.compile_seconds();
    FloatTarget target(w, h);
    const int strata = strata_per_axis(settings.spp);

    std::vector<double> frame_times;
    for (int f = 0; f < std::max(frames, 1); ++f) {
        start = Clock::now();
        program.draw(settings.trace, view_of(scene.camera), w, h, strata, false);
        glFinish();
        frame_times.push_back(since(start));
    }
    if (glGetError() != GL_NO_ERROR) throw GlError("OpenGL reported an error while rendering");
    t.first_frame_seconds = frame_times.front();
    t.frames = static_cast<int>(frame_times.size());
    if (frame_times.size() > 1) {
        std::vector<double> rest(frame_times.begin() + 1, frame_times.end());
        std::nth_element(rest.begin(), rest.begin() + rest.size() / 2, rest.end());
        t.frame_seconds = rest[rest.size() / 2];
    } else {
        t.frame_seconds = t.first_frame_seconds;
    }

    RenderedImage image(w, h);
    const std::vector<float> colour = target.read(0, w, h);
    const std::vector<float> aov = target.read(1, w, h);
    const std::vector<float> normal = target.read(2, w, h);
    for (int y = 0; y < h; ++y) {
        const std::size_t src_row = static_cast<std::size_t>(h - 1 - y) * w;  // GL rows go up
        for (int x = 0; x < w; ++x) {
            const std::size_t s = 4 * (src_row + x), d = static_cast<std::size_t>(y) * w + x;
            for (int c = 0; c < 3; ++c) {
                image.rgb[3 * d + c] = colour[s + c];
                image.normal[3 * d + c] = normal[s + c];
            }
            image.id[d] = aov[s + 0];
            image.depth[d] = aov[s + 1];
        }
    }
    if (timing) *timing = t;
    return image;
}

}  // namespace rt
