#include "gl/gl_viewer.h"

#include <epoxy/gl.h>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "core/light_units.h"
#include "gl/gl_program.h"
#include "io/image_io.h"

namespace rt {
namespace {

const char* kKeys =
    "rtdemo view: drag with the left button to orbit, scroll to dolly;\n"
    "  M cycles paper/classic/physical, S shadows, R reflection, T refraction on/off,\n"
    "  P saves a screenshot (rtdemo-screenshot-N.png), Esc or Q quits.\n";

struct ViewState {
    Mode mode = Mode::paper;
    TraceOptions trace;
    point3 target;
    float distance = 1, yaw = 0, pitch = 0;
    bool dragging = false;
    double last_x = 0, last_y = 0;
    int screenshot_count = 0;
    bool want_screenshot = false;
};

void error_callback(int code, const char* text) {
    std::fprintf(stderr, "rtdemo: GLFW error %d: %s\n", code, text);
}

point3 eye_of(const ViewState& s) {
    const float cp = std::cos(s.pitch);
    return s.target +
           vec3{cp * std::sin(s.yaw), std::sin(s.pitch), cp * std::cos(s.yaw)} * s.distance;
}

void save_screenshot(const std::string& path, int w, int h) {
    std::vector<unsigned char> pixels(3u * w * h);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadBuffer(GL_BACK);
    glReadPixels(0, 0, w, h, GL_RGB, GL_UNSIGNED_BYTE, pixels.data());
    std::vector<unsigned char> flipped(pixels.size());
    for (int y = 0; y < h; ++y)
        std::copy_n(pixels.data() + 3u * w * (h - 1 - y), 3u * w, flipped.data() + 3u * w * y);
    write_png_bytes(path, w, h, flipped);  // already display-encoded by the shader
}

struct GlfwSession {
    GlfwSession() {
        glfwSetErrorCallback(error_callback);
        if (!glfwInit())
            throw GlError("cannot open a window: no display (set DISPLAY, or run under xvfb-run)");
    }
    ~GlfwSession() { glfwTerminate(); }
};

using Window = std::unique_ptr<GLFWwindow, void (*)(GLFWwindow*)>;

// A window with a current OpenGL 4.3 core context, not resizable when it renders a fixed
// number of frames (automation), drawn without waiting for the display's refresh.
Window open_window(const ViewerOptions& options) {
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
    glfwWindowHint(GLFW_RESIZABLE, options.frames > 0 ? GLFW_FALSE : GLFW_TRUE);
    Window window(glfwCreateWindow(options.width, options.height, "rtdemo view", nullptr, nullptr),
                  glfwDestroyWindow);
    if (!window) throw GlError("cannot create a window with an OpenGL 4.3 core context");
    glfwMakeContextCurrent(window.get());
    glfwSwapInterval(0);
    return window;
}

// The orbit starts at the scene's camera: its distance and angles around the look-at point.
ViewState initial_state(const Scene& scene, const ViewerOptions& options) {
    ViewState state;
    state.trace = options.trace;
    state.target = scene.camera.look_at;
    const vec3 offset = scene.camera.position - scene.camera.look_at;
    state.distance = length(offset);
    state.yaw = std::atan2(offset.x, offset.z);
    state.pitch = std::asin(offset.y / state.distance);
    return state;
}

ViewState& state_of(GLFWwindow* w) { return *static_cast<ViewState*>(glfwGetWindowUserPointer(w)); }

Mode next_mode(Mode mode) {
    return mode == Mode::paper     ? Mode::classic
           : mode == Mode::classic ? Mode::physical
                                   : Mode::paper;
}

void on_key(GLFWwindow* w, int key, int, int action, int) {
    if (action != GLFW_PRESS) return;
    ViewState& s = state_of(w);
    switch (key) {
        case GLFW_KEY_ESCAPE:
        case GLFW_KEY_Q:
            glfwSetWindowShouldClose(w, GLFW_TRUE);
            break;
        case GLFW_KEY_M:
            s.mode = next_mode(s.mode);
            s.trace.quirks = quirks_for(s.mode);
            break;
        case GLFW_KEY_S:
            s.trace.shadows = !s.trace.shadows;
            break;
        case GLFW_KEY_R:
            s.trace.reflection = !s.trace.reflection;
            break;
        case GLFW_KEY_T:
            s.trace.refraction = !s.trace.refraction;
            break;
        case GLFW_KEY_P:
            s.want_screenshot = true;
            break;
        default:
            break;
    }
}

void on_mouse_button(GLFWwindow* w, int button, int action, int) {
    ViewState& s = state_of(w);
    if (button == GLFW_MOUSE_BUTTON_LEFT) {
        s.dragging = action == GLFW_PRESS;
        glfwGetCursorPos(w, &s.last_x, &s.last_y);
    }
}

void on_cursor(GLFWwindow* w, double x, double y) {
    ViewState& s = state_of(w);
    if (!s.dragging) return;
    s.yaw -= static_cast<float>(x - s.last_x) * 0.005f;
    s.pitch =
        std::fmax(-1.5f, std::fmin(1.5f, s.pitch + static_cast<float>(y - s.last_y) * 0.005f));
    s.last_x = x;
    s.last_y = y;
}

void on_scroll(GLFWwindow* w, double, double dy) {
    state_of(w).distance *= std::pow(0.9f, static_cast<float>(dy));
}

// The input callbacks steer `state`, which must outlive the window.
void attach(GLFWwindow* window, ViewState& state) {
    glfwSetWindowUserPointer(window, &state);
    glfwSetKeyCallback(window, on_key);
    glfwSetMouseButtonCallback(window, on_mouse_button);
    glfwSetCursorPosCallback(window, on_cursor);
    glfwSetScrollCallback(window, on_scroll);
}

// Ray-traces one frame into the window's back buffer; returns its time in milliseconds.
double draw_frame(const Scene& scene, const ViewState& state, TraceProgram& program, int fb_w,
                  int fb_h) {
    const auto start = std::chrono::steady_clock::now();
    if (fb_w > 0 && fb_h > 0) {
        GlView view = view_of(scene.camera);
        view.position = eye_of(state);
        glBindFramebuffer(GL_FRAMEBUFFER, 0);
        program.draw(state.trace, view, fb_w, fb_h, 1, true);
        glFinish();
    }
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
        .count();
}

// P pressed, or the last of --frames with --screenshot: the back buffer as a PNG.
void save_if_asked(ViewState& state, const ViewerOptions& options, bool last, int fb_w, int fb_h) {
    if (!state.want_screenshot && !(last && !options.screenshot.empty())) return;
    const std::string path =
        last && !options.screenshot.empty()
            ? options.screenshot
            : "rtdemo-screenshot-" + std::to_string(++state.screenshot_count) + ".png";
    save_screenshot(path, fb_w, fb_h);
    std::fprintf(stderr, "rtdemo: saved %s\n", path.c_str());
    state.want_screenshot = false;
}

void show_title(GLFWwindow* window, const ViewState& state, double smoothed_ms) {
    char title[160];
    std::snprintf(title, sizeof title, "rtdemo view - %s - %.1f ms/frame%s%s%s",
                  mode_name(state.mode), smoothed_ms, state.trace.shadows ? "" : " - no shadows",
                  state.trace.reflection ? "" : " - no reflection",
                  state.trace.refraction ? "" : " - no refraction");
    glfwSetWindowTitle(window, title);
}

}  // namespace

void run_viewer(const Scene& scene, const ViewerOptions& options) {
    GlfwSession session;
    Window window = open_window(options);
    ViewState state = initial_state(scene, options);
    attach(window.get(), state);
    TraceProgram program(scene, options.trace);
    if (options.frames == 0) std::fputs(kKeys, stdout);
    int frame = 0;
    double smoothed_ms = 0;
    while (!glfwWindowShouldClose(window.get())) {
        int fb_w = 0, fb_h = 0;
        glfwGetFramebufferSize(window.get(), &fb_w, &fb_h);
        const double ms = draw_frame(scene, state, program, fb_w, fb_h);
        smoothed_ms = frame == 0 ? ms : 0.9 * smoothed_ms + 0.1 * ms;
        ++frame;
        const bool last = options.frames > 0 && frame >= options.frames;
        save_if_asked(state, options, last, fb_w, fb_h);
        show_title(window.get(), state, smoothed_ms);
        glfwSwapBuffers(window.get());
        glfwPollEvents();
        if (last) break;
    }
}

}  // namespace rt
