#include "io/image_io.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace rt {
namespace {
namespace fs = std::filesystem;

TEST(ImageIo, SrgbEncodingOfKnownValues) {
    EXPECT_EQ(to_srgb8(0.0f), 0);
    EXPECT_EQ(to_srgb8(1.0f), 255);
    EXPECT_EQ(to_srgb8(2.0f), 255);  // clamped
    EXPECT_EQ(to_srgb8(0.5f), 188);  // 1.055 * 0.5^(1/2.4) - 0.055 = 0.7354
    EXPECT_EQ(to_srgb8(0.002f), 7);  // linear segment: 12.92 * 0.002 * 255 = 6.6
    EXPECT_EQ(to_srgb8(std::numeric_limits<float>::quiet_NaN()), 0);
}

// The paper's program family writes (unsigned char)(std::min(1.f, x) * 255).
unsigned char paper_byte(float x) { return static_cast<unsigned char>(std::min(1.f, x) * 255); }

TEST(ImageIo, LinearEncodingOfHandPickedValues) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    // 0.5 * 255 = 127.5; 0.999 * 255 = 254.745; 0.25 * 255 = 63.75.
    EXPECT_EQ(to_linear8(0.5f, PpmRounding::truncate), 127);
    EXPECT_EQ(to_linear8(0.5f, PpmRounding::round), 128);
    EXPECT_EQ(to_linear8(0.999f, PpmRounding::truncate), 254);
    EXPECT_EQ(to_linear8(0.999f, PpmRounding::round), 255);
    EXPECT_EQ(to_linear8(0.25f, PpmRounding::truncate), 63);
    EXPECT_EQ(to_linear8(0.25f, PpmRounding::round), 64);
    for (PpmRounding r : {PpmRounding::truncate, PpmRounding::round}) {
        EXPECT_EQ(to_linear8(1.2f, r), 255);
        EXPECT_EQ(to_linear8(1.0f, r), 255);
        EXPECT_EQ(to_linear8(0.0f, r), 0);
        EXPECT_EQ(to_linear8(-0.5f, r), 0);  // the paper's cast: undefined below -1
        EXPECT_EQ(to_linear8(-7.0f, r), 0);
        EXPECT_EQ(to_linear8(nan, r), 0);  // the paper's cast writes 255 (min(1, NaN) = 1)
    }
}

// write_ppm converts four values at a time: every byte must be the scalar convention's, the
// paper's cast of the clamped product (truncate) or std::lround of it (round), including ties
// (x.5 after scaling), level edges, NaN, +-0, denormals, infinities and a sweep of bit patterns.
TEST(ImageIo, PpmBytesFollowBothConventionsForAwkwardValues) {
    const float inf = std::numeric_limits<float>::infinity();
    std::vector<float> values = {0.5f / 255,  1.5f / 255,  254.5f / 255,
                                 0.49999997f, 0.50000006f, -0.0f,
                                 0.0f,        1e-40f,      -1e-40f,
                                 1.0f,        0.99999994f, 1.00000012f,
                                 inf,         -inf,        std::numeric_limits<float>::quiet_NaN()};
    for (int k = 0; k <= 255 * 8; ++k) values.push_back(static_cast<float>(k) / (255.0f * 8));
    for (int k = 0; k <= 255; ++k) {  // the neighbours of each tie and of each level's edge
        for (float x : {(k + 0.5f) / 255.0f, k / 255.0f}) {
            values.push_back(std::nextafter(x, 0.0f));
            values.push_back(x);
            values.push_back(std::nextafter(x, 1.0f));
        }
    }
    // About a million bit patterns spread over all 2^32 (a prime stride): every sign,
    // exponent and NaN payload class.
    for (std::uint64_t bits = 0; bits < (std::uint64_t{1} << 32); bits += 4093) {
        const std::uint32_t b = static_cast<std::uint32_t>(bits);
        float x;
        std::memcpy(&x, &b, sizeof x);
        values.push_back(x);
    }
    while (values.size() % 3) values.push_back(0.25f);
    RenderedImage img(static_cast<int>(values.size() / 3), 1);
    std::copy(values.begin(), values.end(), img.rgb.begin());
    for (PpmRounding rounding : {PpmRounding::truncate, PpmRounding::round}) {
        const fs::path path = fs::temp_directory_path() / "rtdemo_ppm_bytes_test.ppm";
        write_ppm(path.string(), img, rounding);
        std::ifstream in(path, std::ios::binary);
        std::string magic;
        int w = 0, h = 0, maxval = 0;
        in >> magic >> w >> h >> maxval;
        in.get();
        std::vector<char> bytes(values.size());
        in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
        ASSERT_TRUE(in);
        in.close();
        fs::remove(path);
        int mismatches = 0;
        for (std::size_t i = 0; i < values.size() && mismatches < 10; ++i) {
            const float c =
                std::isnan(values[i]) ? 0.0f : std::fmin(1.0f, std::fmax(0.0f, values[i]));
            const unsigned char expected =
                rounding == PpmRounding::truncate
                    ? paper_byte(c)
                    : static_cast<unsigned char>(std::lround(c * 255.0f));
            const unsigned char got = static_cast<unsigned char>(bytes[i]);
            if (got != expected) ++mismatches;
            EXPECT_EQ(got, expected) << "value " << values[i] << " rounding "
                                     << (rounding == PpmRounding::round ? "round" : "truncate");
            EXPECT_EQ(got, to_linear8(values[i], rounding)) << "value " << values[i];
        }
    }
}

TEST(ImageIo, TruncationEqualsThePapersCastOnZeroToOne) {
    // Every level boundary k/255 and its float neighbours, and a fine grid between them.
    for (int k = 0; k <= 255; ++k) {
        const float edge = k / 255.0f;
        for (float x : {std::nextafter(edge, 0.0f), edge, std::nextafter(edge, 1.0f)}) {
            if (x >= 0.0f && x <= 1.0f) {
                ASSERT_EQ(to_linear8(x, PpmRounding::truncate), paper_byte(x)) << x;
            }
        }
    }
    for (int i = 0; i <= 1 << 16; ++i) {
        const float x = static_cast<float>(i) / (1 << 16);
        ASSERT_EQ(to_linear8(x, PpmRounding::truncate), paper_byte(x)) << x;
    }
}

TEST(ImageIo, PpmRoundingParsesItsTwoNames) {
    EXPECT_EQ(parse_ppm_rounding("truncate"), PpmRounding::truncate);
    EXPECT_EQ(parse_ppm_rounding("round"), PpmRounding::round);
    EXPECT_THROW(parse_ppm_rounding("nearest"), std::invalid_argument);
}

std::string write_and_read_ppm(const RenderedImage& img, PpmRounding rounding) {
    const fs::path path = fs::temp_directory_path() / "rtdemo_image_io_test.ppm";
    write_ppm(path.string(), img, rounding);
    std::ifstream in(path, std::ios::binary);
    std::string data((std::istreambuf_iterator<char>(in)), {});
    fs::remove(path);
    return data;
}

TEST(ImageIo, PpmHasHeaderAndLinearBytesTruncatedByDefault) {
    RenderedImage img(2, 1);
    const float values[] = {0.5f, 0.0f, 1.0f, 2.0f, 0.25f, 0.0f};
    std::copy(std::begin(values), std::end(values), img.rgb.begin());
    const std::string header = "P6\n2 1\n255\n";
    const std::string truncated = write_and_read_ppm(img, PpmRounding::truncate);
    ASSERT_EQ(truncated.size(), header.size() + 6);
    EXPECT_EQ(truncated.substr(0, header.size()), header);
    const std::string expected_truncated = {127, 0, '\xff', '\xff', 63, 0};
    EXPECT_EQ(truncated.substr(header.size()), expected_truncated);
    const std::string rounded = write_and_read_ppm(img, PpmRounding::round);
    const std::string expected_rounded = {'\x80', 0, '\xff', '\xff', 64, 0};
    EXPECT_EQ(rounded.substr(header.size()), expected_rounded);

    // The default argument is truncation.
    const fs::path path = fs::temp_directory_path() / "rtdemo_image_io_default.ppm";
    write_ppm(path.string(), img);
    std::ifstream in(path, std::ios::binary);
    const std::string by_default((std::istreambuf_iterator<char>(in)), {});
    fs::remove(path);
    EXPECT_EQ(by_default, truncated);
}

TEST(ImageIo, UnwritableDirectoryFailsAndLeavesNoFile) {
    RenderedImage img(2, 2);
    EXPECT_THROW(write_exr("/nonexistent-dir/out.exr", img, {}), OutputError);
    EXPECT_THROW(write_png("/nonexistent-dir/out.png", img), OutputError);
    EXPECT_FALSE(fs::exists("/nonexistent-dir"));
}

TEST(ImageIo, ExrWriteReplacesAtomically) {
    RenderedImage img(4, 3);
    const fs::path path = fs::temp_directory_path() / "rtdemo_image_io_test.exr";
    write_exr(path.string(), img, {{"rtval.scene", "unit"}});
    EXPECT_TRUE(fs::exists(path));
    for (const auto& entry : fs::directory_iterator(fs::temp_directory_path()))
        EXPECT_EQ(entry.path().string().find("rtdemo_image_io_test.exr.tmp"), std::string::npos);
    fs::remove(path);
}

}  // namespace
}  // namespace rt
