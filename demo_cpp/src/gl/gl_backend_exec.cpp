// The GL backend in rtdemo, which carries no OpenGL (CMakeLists.txt says why): the same
// command line run again as rtdemo-gl, installed beside it (gl_backend.h).
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "gl/gl_backend.h"

namespace rt {
namespace {

char** g_argv = nullptr;

[[noreturn]] void exec_gl_sibling() {
    std::string self(4096, '\0');
    const ssize_t n = ::readlink("/proc/self/exe", self.data(), self.size() - 1);
    if (n <= 0) throw GlError("cannot locate rtdemo-gl: /proc/self/exe unreadable");
    self.resize(static_cast<std::size_t>(n));
    const std::string sibling = self.substr(0, self.rfind('/') + 1) + "rtdemo-gl";
    // A build without GL reached again through this variable was installed as rtdemo-gl:
    // an error, not an endless chain of execs.
    if (std::getenv("RTDEMO_GL_EXEC"))
        throw GlError(sibling + " is a build without the GL backend (installed wrongly)");
    ::setenv("RTDEMO_GL_EXEC", "1", 1);
    std::fflush(nullptr);
    ::execv(sibling.c_str(), g_argv);
    throw GlError("the GL backend and the viewer are in " + sibling +
                  ", which cannot run: " + std::strerror(errno));
}

}  // namespace

void keep_command_line(char** argv) { g_argv = argv; }

// Reached after the command line and the scene were checked: a bad command fails here alike.
RenderedImage render_with_gl(const Scene&, const RenderSettings&, int, GlTiming*) {
    exec_gl_sibling();
}

// Before the scene is read: rtdemo-gl reads it.
void view_with_gl(const RenderArgs&, int, const std::string&) { exec_gl_sibling(); }

}  // namespace rt
