// rtdemo's two commands, given the arguments after their name. Each returns the exit status of
// a success and throws what main maps to the others (UsageError 2, SceneError 3, OutputError 4,
// GlError 5, anything else 1).
#pragma once

#include <string>
#include <vector>

namespace rt {

int run_render(const std::vector<std::string>& args);       // render_command.cpp
int run_view(const std::vector<std::string>& args);         // view_command.cpp
int run_trace_pixel(const std::vector<std::string>& args);  // trace_pixel_command.cpp
void print_trace_pixel_help();                              // trace_pixel_command.cpp

}  // namespace rt
