// rtdemo's --help texts: the program's, render's (with the catalogue of named mistakes) and
// view's.
#pragma once

#include <cstdio>

namespace rt {

void print_top_help(std::FILE* to);  // stdout for --help, stderr when no command is given
void print_render_help();
void print_view_help();

}  // namespace rt
