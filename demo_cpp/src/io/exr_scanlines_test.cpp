// The directly written EXR read back by OpenEXR itself, uncompressed, RLE and ZIP: every channel
// bit for bit, the attributes, and the layout OpenEXR reports (compression, float channels, data
// window), including blocks stored raw because compressing did not shrink them.
#include "io/exr_scanlines.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfStringAttribute.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "io/exr_test_support.h"

namespace rt {
namespace {
namespace fs = std::filesystem;
using test::expect_pixels;
using test::read_channel;
using test::sample_image;

float random_float(std::mt19937& rng) {
    const std::uint32_t bits = static_cast<std::uint32_t>(rng());
    float f;
    std::memcpy(&f, &bits, sizeof f);
    return f;
}

// What the compressors must cope with: whole lines of zeros (runs longer than one count byte
// holds), lines half zeros and half random bits (runs and literals in one block), the smooth
// ramps of sample_image, and lines of random bits only (groups of literals, and blocks that do
// not shrink, stored raw). Rows 16 and below are random, so ZIP's last block is stored raw.
RenderedImage mixed_image(int w, int h) {
    RenderedImage img = sample_image(w, h);
    std::mt19937 rng(20240601);
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * w + x;
            if (y >= 4 && y < 7) {  // constant
                for (int c = 0; c < 3; ++c) img.rgb[3 * i + c] = img.normal[3 * i + c] = 0.0f;
                img.id[i] = img.depth[i] = 0.0f;
            } else if ((y >= 7 && y < 10 && x < w / 2) || y >= 16) {  // noise
                for (int c = 0; c < 3; ++c) {
                    img.rgb[3 * i + c] = random_float(rng);
                    img.normal[3 * i + c] = random_float(rng);
                }
                img.id[i] = random_float(rng);
                img.depth[i] = random_float(rng);
            } else if (y >= 7 && y < 10) {  // constant
                for (int c = 0; c < 3; ++c) img.rgb[3 * i + c] = img.normal[3 * i + c] = 0.0f;
                img.id[i] = img.depth[i] = 0.0f;
            }
        }
    }
    return img;
}

// Every pixel random bits: no block shrinks.
RenderedImage random_image(int w, int h) {
    RenderedImage img(w, h);
    std::mt19937 rng(7);
    for (auto* plane : {&img.rgb, &img.normal, &img.id, &img.depth})
        for (float& v : *plane) v = random_float(rng);
    return img;
}

struct CompressionCase {
    const char* label;
    ExrCompression compression;
    Imf::Compression openexr;
    int block_lines;
};

class ExrScanlinesCompression : public ::testing::TestWithParam<CompressionCase> {};

INSTANTIATE_TEST_SUITE_P(
    Exr, ExrScanlinesCompression,
    ::testing::Values(CompressionCase{"none", ExrCompression::none, Imf::NO_COMPRESSION, 1},
                      CompressionCase{"rle", ExrCompression::rle, Imf::RLE_COMPRESSION, 1},
                      CompressionCase{"zip", ExrCompression::zip, Imf::ZIP_COMPRESSION, 16}),
    [](const ::testing::TestParamInfo<CompressionCase>& info) { return info.param.label; });

TEST_P(ExrScanlinesCompression, OpenExrReadsBackEveryChannelBitForBitAndTheAttributes) {
    const CompressionCase& param = GetParam();
    const int w = 37, h = 21;  // not a multiple of ZIP's 16-line blocks
    const RenderedImage img = mixed_image(w, h);
    const fs::path path =
        fs::temp_directory_path() / (std::string("rtdemo_exr_scanlines_") + param.label + ".exr");
    write_exr_scanlines(path.string(), img,
                        {{"rtval.scene", "classic"},
                         {"rtval.rays_camera", "307200"},
                         {"rtval.a_name_longer_than_thirty_one_chars", "x"}},
                        param.compression);
    // Compressed, the file is smaller than the pixels (the noise rows cannot make up for that).
    if (param.compression != ExrCompression::none) {
        EXPECT_LT(fs::file_size(path), static_cast<std::uintmax_t>(w) * h * 32);
    }
    {
        Imf::InputFile in(path.c_str());
        const Imf::Header& header = in.header();
        EXPECT_EQ(header.compression(), param.openexr);
        EXPECT_EQ(header.dataWindow().max.x, w - 1);
        EXPECT_EQ(header.dataWindow().max.y, h - 1);
        int channels = 0;
        for (auto it = header.channels().begin(); it != header.channels().end(); ++it, ++channels)
            EXPECT_EQ(it.channel().type, Imf::FLOAT) << it.name();
        EXPECT_EQ(channels, 8);
        EXPECT_EQ(header.typedAttribute<Imf::StringAttribute>("rtval.scene").value(), "classic");
        EXPECT_EQ(header.typedAttribute<Imf::StringAttribute>("rtval.rays_camera").value(),
                  "307200");
        EXPECT_EQ(
            header.typedAttribute<Imf::StringAttribute>("rtval.a_name_longer_than_thirty_one_chars")
                .value(),
            "x");
        expect_pixels(in, img);
    }
    fs::remove(path);
}

// --exr-channels rgb: B, G, R alone, from a frame without AOV planes, read back bit for bit;
// a frame without them cannot be written with every channel.
TEST_P(ExrScanlinesCompression, TheColourAloneIsThreeChannelsReadBackBitForBit) {
    const CompressionCase& param = GetParam();
    const RenderedImage img = test::without_aovs(mixed_image(37, 21));
    const fs::path path =
        fs::temp_directory_path() / (std::string("rtdemo_exr_rgb_") + param.label + ".exr");
    write_exr_scanlines(path.string(), img, {{"rtval.scene", "classic"}}, param.compression, 0,
                        ExrChannels::rgb);
    {
        Imf::InputFile in(path.c_str());
        EXPECT_EQ(in.header().compression(), param.openexr);
        EXPECT_EQ(test::channel_names(in), (std::vector<std::string>{"B", "G", "R"}));
        expect_pixels(in, img, false);
    }
    EXPECT_THROW(write_exr_scanlines(path.string(), img, {}, param.compression),
                 std::runtime_error);
    fs::remove(path);
}

// Random bits do not shrink: every block is stored raw, so the file is exactly the header, the
// offset table and per block y, byte count and the raw lines, and OpenEXR still reads it.
TEST_P(ExrScanlinesCompression, BlocksThatDoNotShrinkAreStoredRaw) {
    const CompressionCase& param = GetParam();
    const int w = 37, h = 21;
    const RenderedImage img = random_image(w, h);
    const fs::path path =
        fs::temp_directory_path() / (std::string("rtdemo_exr_raw_") + param.label + ".exr");
    write_exr_scanlines(path.string(), img, {}, param.compression);
    const std::uintmax_t blocks = (h + param.block_lines - 1) / param.block_lines;
    // The header's size: the uncompressed file's, less its table and block headers.
    write_exr_scanlines(path.string() + ".none", img, {}, ExrCompression::none);
    const std::uintmax_t header =
        fs::file_size(path.string() + ".none") - static_cast<std::uintmax_t>(h) * (16 + w * 32);
    EXPECT_EQ(fs::file_size(path), header + blocks * 16 + static_cast<std::uintmax_t>(h) * w * 32);
    {
        Imf::InputFile in(path.c_str());
        EXPECT_EQ(in.header().compression(), param.openexr);
        expect_pixels(in, img);
    }
    fs::remove(path);
    fs::remove(path.string() + ".none");
}

// The compressed file does not depend on how many threads compressed its blocks.
TEST(ExrScanlines, OneThreadOrManyWriteTheSameBytes) {
    const RenderedImage img = mixed_image(37, 21);
    std::string bytes[2];
    for (int threads : {1, 3}) {
        const fs::path path = fs::temp_directory_path() /
                              ("rtdemo_exr_threads_" + std::to_string(::getpid()) + ".exr");
        write_exr_scanlines(path.string(), img, {}, ExrCompression::zip, threads);
        std::ifstream in(path, std::ios::binary);
        bytes[threads == 1 ? 0 : 1].assign(std::istreambuf_iterator<char>(in),
                                           std::istreambuf_iterator<char>());
        fs::remove(path);
    }
    EXPECT_FALSE(bytes[0].empty());
    EXPECT_EQ(bytes[0], bytes[1]);
}

TEST(ExrScanlines, UnwritablePathNamesTheFile) {
    try {
        write_exr_scanlines("/nonexistent-dir/x.exr", sample_image(2, 2), {});
        ADD_FAILURE() << "no error";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("/nonexistent-dir/x.exr"), std::string::npos);
    }
}

// Only regular files are written: a FIFO (no reader: it would block) and a device are refused
// untouched, naming the path and what it is.
TEST(ExrScanlines, RefusesAFifoAndADevice) {
    const fs::path fifo = fs::temp_directory_path() / "rtdemo_exr_scanlines_fifo";
    fs::remove(fifo);
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    for (const std::string& path : {fifo.string(), std::string("/dev/null")}) {
        try {
            write_exr_scanlines(path, sample_image(2, 2), {});
            ADD_FAILURE() << "no error for " << path;
        } catch (const std::runtime_error& e) {
            EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
        }
    }
    EXPECT_TRUE(fs::is_fifo(fifo));
    fs::remove(fifo);
}

}  // namespace
}  // namespace rt
