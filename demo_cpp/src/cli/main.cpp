// rtdemo: the paper's ray tracer as a command-line program. main picks the command and maps
// its errors to exit codes (commands.h).
#include <malloc.h>

#include <climits>
#include <csignal>
#include <cstdio>
#include <new>
#include <string>
#include <vector>

#include "cli/cli_args.h"
#include "cli/commands.h"
#include "cli/help_text.h"
#include "core/ray_budget.h"
#include "gl/gl_backend.h"
#include "io/image_io.h"
#include "io/scene_loader.h"

namespace {

using namespace rt;

constexpr int kExitUsage = 2;
constexpr int kExitScene = 3;
constexpr int kExitOutput = 4;
constexpr int kExitGl = 5;
constexpr int kExitRayBudget = 6;

// How the process allocates and meets a file-size limit: the same for every command.
void configure_process() {
    // A render is a short batch job: blocks under 32 MB that it frees are kept for reuse until
    // the process ends, not handed back to the kernel midway (each unmap or trim is a system
    // call that flushes the address translations of every core the process ran on: 0.2-0.5 ms
    // at the end of a frame, bench/NOTES.md; larger blocks, a frame plane over ~2.8 Mpixels,
    // are still mapped and unmapped on their own); the main heap grows 4 MB at a time. Each worker
    // thread keeps its own arena (malloc's default): with one shared arena the two threads'
    // first allocations woke each other through its lock, and Linux then often ran both on
    // the waker's CPU for milliseconds (perf sched, bench/NOTES.md).
    mallopt(M_MMAP_THRESHOLD, 32 << 20);
    mallopt(M_TRIM_THRESHOLD, INT_MAX);
    mallopt(M_TOP_PAD, 4 << 20);
    // Past a file-size limit a write fails (exit 4, the temporary file removed) instead of
    // the process being killed with its temporary file left behind.
    std::signal(SIGXFSZ, SIG_IGN);
}

// --help, --version or a command; throws what main maps to exit codes.
int run_command(const std::vector<std::string>& args) {
    if (args.empty() || args[0] == "--help" || args[0] == "-h" || args[0] == "help") {
        print_top_help(args.empty() ? stderr : stdout);
        return args.empty() ? kExitUsage : 0;
    }
    if (args[0] == "--version") {
        std::puts("rtdemo " RTVAL_VERSION);
        return 0;
    }
    const std::vector<std::string> rest(args.begin() + 1, args.end());
    for (const std::string& a : rest)
        if (a == "--help" || a == "-h") {
            if (args[0] == "render") {
                print_render_help();
                return 0;
            }
            if (args[0] == "view") {
                print_view_help();
                return 0;
            }
            if (args[0] == "trace-pixel") {
                print_trace_pixel_help();
                return 0;
            }
        }
    if (args[0] == "render") return run_render(rest);
    if (args[0] == "view") return run_view(rest);
    if (args[0] == "trace-pixel") return run_trace_pixel(rest);
    throw UsageError("unknown command '" + args[0] + "' (see rtdemo --help)");
}

}  // namespace

int main(int argc, char** argv) {
    configure_process();
    keep_command_line(argv);
    try {
        return run_command(std::vector<std::string>(argv + 1, argv + argc));
    } catch (const UsageError& e) {
        std::fprintf(stderr, "rtdemo: error: %s\n", e.what());
        return kExitUsage;
    } catch (const SceneError& e) {
        std::fprintf(stderr, "rtdemo: error: %s\n", e.what());
        return kExitScene;
    } catch (const OutputError& e) {
        std::fprintf(stderr, "rtdemo: error: %s\n", e.what());
        return kExitOutput;
    } catch (const GlError& e) {
        std::fprintf(stderr, "rtdemo: error: OpenGL: %s\n", e.what());
        return kExitGl;
    } catch (const RayBudgetExhausted& e) {
        std::fprintf(stderr, "rtdemo: %s\n", e.what());
        return kExitRayBudget;
    } catch (const std::bad_alloc&) {
        std::fprintf(stderr, "rtdemo: error: out of memory\n");
        return 1;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "rtdemo: error: %s\n", e.what());
        return 1;
    }
}
