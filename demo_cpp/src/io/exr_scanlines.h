// The demo's EXR written directly (OpenEXR 2.0 file layout, single-part scanline file): the
// same channels and attributes as the OpenEXR writer, without linking the library. Writing the
// 9.8 MB frame through its per-line slice machinery cost more than tracing it (bench/NOTES.md),
// and loading its shared libraries cost every rtdemo process about 1 ms at start-up.
// Uncompressed (one line per block), RLE (one line per block) or ZIP (zlib, 16 lines per block).
#pragma once

#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "core/band_sink.h"
#include "io/image.h"

namespace rt {

enum class ExrCompression { none, rle, zip };
// Every channel below, or R, G, B alone (no AOVs: a render judged by its colour only); the
// *_path sets add the path-class AOV "path" (core/ray_tree.h), opt-in: the scalar tracer
// traces the frame a second time for it.
enum class ExrChannels { all, rgb, all_path, rgb_path };
inline bool exr_has_aovs(ExrChannels c) {
    return c == ExrChannels::all || c == ExrChannels::all_path;
}
inline bool exr_has_path(ExrChannels c) {
    return c == ExrChannels::all_path || c == ExrChannels::rgb_path;
}

// The header of such a file (magic number to the end-of-header byte): `attributes` as string
// attributes, the channels above, no line offset table.
std::vector<char> exr_header(int w, int h, const std::map<std::string, std::string>& attributes,
                             ExrCompression compression, ExrChannels channels = ExrChannels::all);
// Uncompressed: the bytes of one line's block (y, byte count, each channel's row).
std::size_t exr_line_block_bytes(int w, ExrChannels channels = ExrChannels::all);
// Writes the blocks of lines [y0, y0 + rows) to `out` from `pixels`, which hold just these rows
// (row stride w); returns the end of what was written.
char* exr_line_blocks(char* out, int y0, int rows, int w, const BandPixels& pixels,
                      ExrChannels channels = ExrChannels::all);

// Writes `image` to `path` (created or replaced; only ever a regular file): float32 channels B,
// G, N.X, N.Y, N.Z, R, depth, id (stored in name order, as OpenEXR does; B, G, R alone for
// ExrChannels::rgb, when the frame needs no AOV planes) and `attributes` as string attributes.
// Compressed blocks are compressed on `threads` threads (0: every core; zlib level 1 for ZIP); a
// block that does not shrink is stored raw, as the format allows. Throws std::runtime_error naming
// the path when the file cannot be written.
void write_exr_scanlines(const std::string& path, const RenderedImage& image,
                         const std::map<std::string, std::string>& attributes,
                         ExrCompression compression = ExrCompression::none, int threads = 0,
                         ExrChannels channels = ExrChannels::all);

}  // namespace rt
