// A pixel's ray tree as the JSON of docs/commands/trace-pixel.md ("rtdemo-ray-tree/1").
#pragma once

#include <nlohmann/json.hpp>

#include "core/pixel_trace.h"

namespace rt {

// {"x", "y", "color", "path", "tree"} of one pixel (the header fields are the caller's).
nlohmann::ordered_json pixel_json(const PixelTrace& trace, const Scene& scene, int x, int y);

}  // namespace rt
