// The demo's uncompressed EXR written directly (OpenEXR 2.0 file layout, single-part scanline
// file, one line per block): the same channels and attributes as the OpenEXR writer, without its
// per-line slice machinery, in blocks of lines from one small reused buffer. Writing the 9.8 MB
// frame cost more than tracing it through the library (bench/NOTES.md, issue 20).
#pragma once

#include <map>
#include <string>

#include "image.h"

namespace rt {

// Writes `image` to `path` (created or replaced): float32 channels B, G, N.X, N.Y, N.Z, R,
// depth, id (stored in name order, as OpenEXR does) and `attributes` as string attributes.
// Throws std::runtime_error naming the path when the file cannot be written.
void write_exr_scanlines(const std::string& path, const RenderedImage& image,
                         const std::map<std::string, std::string>& attributes);

}  // namespace rt
