#include "io/image_io.h"

#include <emmintrin.h>
#include <png.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <vector>

#include "io/exr_scanlines.h"
#include "io/file_kind.h"
#include "io/output_file.h"

namespace rt {
namespace fs = std::filesystem;

namespace {

// NaN -> 0. Compares, not fmin/fmax: those were libm calls per channel (bench/NOTES.md).
float clamp01(float v) { return v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f; }

// The temporary file as a stdio stream (created new: AtomicFile::create).
FILE* open_for_writing(AtomicFile& file) {
    const int fd = file.create();
    FILE* fp = ::fdopen(fd, "wb");
    if (!fp) {
        ::close(fd);
        throw OutputError(file.path() + ": cannot open for writing");
    }
    return fp;
}

template <class Encode>
std::vector<unsigned char> to_8bit(const RenderedImage& image, Encode encode) {
    std::vector<unsigned char> out(image.rgb.size());
    for (std::size_t i = 0; i < out.size(); ++i) out[i] = encode(image.rgb[i]);
    return out;
}

}  // namespace

// to_linear8 four values per SSE2 instruction (x86-64's baseline): the same compares, product
// and truncation, so the same bytes (checked against to_linear8 for every float, both
// conventions).
void linear8_encode(const float* v, std::size_t n, PpmRounding rounding, unsigned char* out) {
    std::size_t i = 0;
    // Rounding adds one where the fraction x - trunc(x) is >= 0.5; truncation never does (the
    // fraction is below 1), so one loop serves both conventions.
    const __m128 zero = _mm_setzero_ps(), one = _mm_set1_ps(1.0f), scale = _mm_set1_ps(255.0f),
                 step = _mm_set1_ps(rounding == PpmRounding::round ? 0.5f : 1.0f);
    for (; i + 4 <= n; i += 4) {
        // maxps(x, 0) is x > 0 ? x : 0 (NaN -> 0); minps(x, 1) is x < 1 ? x : 1: clamp01.
        const __m128 x = _mm_mul_ps(_mm_min_ps(_mm_max_ps(_mm_loadu_ps(&v[i]), zero), one), scale);
        const __m128i t = _mm_cvttps_epi32(x);
        const __m128i up = _mm_castps_si128(_mm_cmpge_ps(_mm_sub_ps(x, _mm_cvtepi32_ps(t)), step));
        const __m128i b = _mm_sub_epi32(t, up);  // the mask is -1 where rounding up
        const __m128i packed = _mm_packus_epi16(_mm_packs_epi32(b, b), _mm_setzero_si128());
        const int word = _mm_cvtsi128_si32(packed);
        std::memcpy(&out[i], &word, 4);
    }
    for (; i < n; ++i) out[i] = to_linear8(v[i], rounding);
}

unsigned char to_srgb8(float linear) {
    const float v = clamp01(linear);
    const float s = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
    return static_cast<unsigned char>(std::lround(s * 255.0f));
}

unsigned char to_linear8(float linear, PpmRounding rounding) {
    // The float product, as the paper's program computes it; the cast truncates. Rounding is
    // std::lround for v in [0, 255] without the libm call: v - trunc(v) is exact there.
    const float v = clamp01(linear) * 255.0f;
    const int t = static_cast<int>(v);
    const bool up = rounding == PpmRounding::round && v - static_cast<float>(t) >= 0.5f;
    return static_cast<unsigned char>(t + (up ? 1 : 0));
}

PpmRounding parse_ppm_rounding(const std::string& text) {
    if (text == "truncate") return PpmRounding::truncate;
    if (text == "round") return PpmRounding::round;
    throw std::invalid_argument("expected truncate or round, got '" + text + "'");
}

void check_writable(const std::string& path) {
    fs::path dir = fs::path(path).parent_path();
    if (dir.empty()) dir = ".";
    std::error_code ec;
    if (!fs::is_directory(dir, ec))
        throw OutputError(path + ": cannot write: directory '" + dir.string() + "' does not exist");
    if (::access(dir.c_str(), W_OK) != 0)
        throw OutputError(path + ": cannot write: directory '" + dir.string() +
                          "' is not writable");
    if (fs::is_directory(path, ec)) throw OutputError(path + ": cannot write: it is a directory");
    try {
        check_replaceable(path);  // never turn /dev/full or a FIFO into a regular file
    } catch (const FileKindError& e) {
        throw OutputError(std::string("cannot write ") + e.what());
    }
}

ExrCompression parse_exr_compression(const std::string& text) {
    if (text == "none") return ExrCompression::none;
    if (text == "rle") return ExrCompression::rle;
    if (text == "zip") return ExrCompression::zip;
    throw std::invalid_argument("expected none, rle or zip, got '" + text + "'");
}

ExrChannels parse_exr_channels(const std::string& text) {
    if (text == "all") return ExrChannels::all;
    if (text == "rgb") return ExrChannels::rgb;
    if (text == "all+path") return ExrChannels::all_path;
    if (text == "rgb+path") return ExrChannels::rgb_path;
    throw std::invalid_argument("expected all, rgb, all+path or rgb+path, got '" + text + "'");
}

void write_exr(const std::string& path, const RenderedImage& image,
               const std::map<std::string, std::string>& attributes, ExrCompression compression,
               int threads, ExrChannels channels) {
    check_writable(path);
    AtomicFile file(path);
    try {  // written directly, compressed or not (no OpenEXR at start-up)
        write_exr_scanlines(file.temp(), image, attributes, compression, threads, channels);
    } catch (const std::exception& e) {
        throw OutputError(path + ": cannot write EXR: " + e.what());
    }
    file.commit();
}

void write_png(const std::string& path, const RenderedImage& image) {
    write_png_bytes(path, image.width, image.height, to_8bit(image, to_srgb8));
}

void write_png_bytes(const std::string& path, int width, int height,
                     const std::vector<unsigned char>& bytes) {
    check_writable(path);
    AtomicFile file(path);
    std::unique_ptr<FILE, int (*)(FILE*)> fp(open_for_writing(file), &std::fclose);
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (!png || !info) {
        png_destroy_write_struct(&png, &info);
        throw OutputError(path + ": cannot initialise the PNG writer");
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        throw OutputError(path + ": PNG write failed");
    }
    png_init_io(png, fp.get());
    png_set_IHDR(png, info, width, height, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_sRGB(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    png_write_info(png, info);
    for (int y = 0; y < height; ++y)
        png_write_row(png, bytes.data() + 3u * static_cast<std::size_t>(width) * y);
    png_write_end(png, nullptr);
    png_destroy_write_struct(&png, &info);
    if (std::fflush(fp.get()) != 0 || std::ferror(fp.get()))
        throw OutputError(path + ": write failed");
    fp.reset();
    file.commit();
}

std::string ppm_header(int width, int height) {
    return "P6\n" + std::to_string(width) + " " + std::to_string(height) + "\n255\n";
}

void write_ppm(const std::string& path, const RenderedImage& image, PpmRounding rounding) {
    check_writable(path);
    AtomicFile file(path);
    std::vector<unsigned char> bytes(image.rgb.size());
    linear8_encode(image.rgb.data(), bytes.size(), rounding, bytes.data());
    std::unique_ptr<FILE, int (*)(FILE*)> fp(open_for_writing(file), &std::fclose);
    const std::string header = ppm_header(image.width, image.height);
    std::fwrite(header.data(), 1, header.size(), fp.get());
    std::fwrite(bytes.data(), 1, bytes.size(), fp.get());
    if (std::fflush(fp.get()) != 0 || std::ferror(fp.get()))
        throw OutputError(path + ": write failed");
    fp.reset();
    file.commit();
}

}  // namespace rt
