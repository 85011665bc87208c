// Writers for the demo's outputs. Every writer goes to a temporary name in the target
// directory and renames on success, so a failed write never leaves a partial file.
#pragma once

#include <cstddef>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "io/exr_scanlines.h"
#include "io/image.h"
#include "io/ppm_rounding.h"

namespace rt {

class OutputError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// Throws OutputError when the file's directory does not exist or is not writable.
void check_writable(const std::string& path);

// "none" | "rle" | "zip"; throws std::invalid_argument naming the bad value.
ExrCompression parse_exr_compression(const std::string& text);
// "all" or "rgb" (--exr-channels); throws std::invalid_argument naming what it got.
ExrChannels parse_exr_channels(const std::string& text);

// Float32 EXR: R, G, B (linear, unclamped), id, depth, N.X, N.Y, N.Z (or the colour alone,
// ExrChannels::rgb); `attributes`
// become string attributes of the header (written by exr_scanlines.h). Uncompressed by
// default: ZIP made writing the file cost more than rendering it (bench/NOTES.md). Compressed
// on `threads` threads (0: every core).
void write_exr(const std::string& path, const RenderedImage& image,
               const std::map<std::string, std::string>& attributes,
               ExrCompression compression = ExrCompression::none, int threads = 0,
               ExrChannels channels = ExrChannels::all);
// 8-bit PNG for people: clamped to [0, 1], sRGB-encoded. NaN is written as 0.
void write_png(const std::string& path, const RenderedImage& image);
// 8-bit RGB bytes (row-major, y down) that are already display-encoded, as a PNG.
void write_png_bytes(const std::string& path, int width, int height,
                     const std::vector<unsigned char>& rgb);
// "truncate" | "round"; throws std::invalid_argument naming the bad value.
PpmRounding parse_ppm_rounding(const std::string& text);

// A binary PPM's header ("P6", size, 255), the bytes before its pixels.
std::string ppm_header(int width, int height);
// The paper's own format: binary P6, linear, clamped, 8-bit (x * 255, truncated by default
// as the paper's program writes it). NaN -> 0.
void write_ppm(const std::string& path, const RenderedImage& image,
               PpmRounding rounding = PpmRounding::truncate);

// to_linear8 of n values, vectorised (the same bytes).
void linear8_encode(const float* v, std::size_t n, PpmRounding rounding, unsigned char* out);

// Display encodings, exposed for tests and the GL backend's screenshots.
unsigned char to_srgb8(float linear);
// Clamped to [0, 1] first and NaN -> 0: the paper's cast is undefined below -1 (a negative
// float into unsigned char) and turns NaN into 255 (std::min(1.f, NaN) is 1).
unsigned char to_linear8(float linear, PpmRounding rounding);

}  // namespace rt
