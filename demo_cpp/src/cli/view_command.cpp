// rtdemo view: render's options, less the file outputs, with --frames and --screenshot.
#include "cli/commands.h"
#include "cli/render_args.h"
#include "gl/gl_backend.h"

namespace rt {
namespace {

bool is_render_only(const std::string& option) {
    for (const char* o : {"-o", "--output", "--png", "--ppm", "--ppm-rounding", "--exr-compression",
                          "--backend", "--spp", "--mistake", "--engine"})
        if (option == o) return true;
    return false;
}

}  // namespace

int run_view(const std::vector<std::string>& args) {
    // Same parser as render; outputs are not allowed, --screenshot takes their place.
    std::vector<std::string> rest;
    std::string screenshot;
    int frames = 0;
    for (std::size_t i = 0; i < args.size(); ++i) {
        if (args[i] == "--screenshot" || args[i] == "--frames") {
            if (i + 1 >= args.size()) throw UsageError(args[i] + ": expected a value");
            if (args[i] == "--screenshot")
                screenshot = args[++i];
            else
                frames = parse_int_arg("--frames", args[++i], 1, 100000);
        } else if (is_render_only(args[i])) {
            throw UsageError(args[i] + " is not an option of view (see rtdemo view --help)");
        } else {
            rest.push_back(args[i]);
        }
    }
    const RenderArgs a = parse_render_args(rest, false);
    if (!screenshot.empty() && frames == 0)
        throw UsageError("--screenshot needs --frames N (press P in the window instead)");
    if (!screenshot.empty()) check_writable(screenshot);
    view_with_gl(a, frames, screenshot);
    return 0;
}

}  // namespace rt
