// The directly written EXR read back by OpenEXR itself: every channel bit for bit, the
// attributes, and the layout OpenEXR reports (uncompressed float channels, data window).
#include "exr_scanlines.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfStringAttribute.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

namespace rt {
namespace {
namespace fs = std::filesystem;

RenderedImage sample_image(int w, int h) {
    RenderedImage img(w, h);
    // Distinct values per channel and pixel, and the awkward ones the demo can produce.
    for (std::size_t i = 0; i < img.rgb.size(); ++i)
        img.rgb[i] = 0.001f * static_cast<float>(i) - 3.0f;
    for (std::size_t i = 0; i < img.normal.size(); ++i)
        img.normal[i] = -0.5f + 1e-4f * static_cast<float>(i);
    for (std::size_t i = 0; i < img.id.size(); ++i) {
        img.id[i] = static_cast<float>(static_cast<int>(i % 7) - 1);
        img.depth[i] = 0.25f * static_cast<float>(i);
    }
    img.rgb[0] = std::numeric_limits<float>::quiet_NaN();
    img.rgb[4] = std::numeric_limits<float>::infinity();
    img.rgb[5] = -0.0f;
    img.normal[2] = 1e-42f;  // denormal
    return img;
}

std::vector<float> read_channel(Imf::InputFile& in, const char* name, int w, int h) {
    std::vector<float> out(static_cast<std::size_t>(w) * h);
    Imf::FrameBuffer fb;
    fb.insert(name, Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(out.data()), sizeof(float),
                               sizeof(float) * static_cast<std::size_t>(w)));
    in.setFrameBuffer(fb);
    in.readPixels(0, h - 1);
    return out;
}

TEST(ExrScanlines, OpenExrReadsBackEveryChannelBitForBitAndTheAttributes) {
    const int w = 37, h = 23;  // not a multiple of any block
    const RenderedImage img = sample_image(w, h);
    const fs::path path = fs::temp_directory_path() / "rtdemo_exr_scanlines_test.exr";
    write_exr_scanlines(path.string(), img,
                        {{"rtval.scene", "classic"},
                         {"rtval.rays_camera", "307200"},
                         {"rtval.a_name_longer_than_thirty_one_chars", "x"}});
    Imf::InputFile in(path.c_str());
    const Imf::Header& header = in.header();
    EXPECT_EQ(header.compression(), Imf::NO_COMPRESSION);
    EXPECT_EQ(header.dataWindow().max.x, w - 1);
    EXPECT_EQ(header.dataWindow().max.y, h - 1);
    int channels = 0;
    for (auto it = header.channels().begin(); it != header.channels().end(); ++it, ++channels)
        EXPECT_EQ(it.channel().type, Imf::FLOAT) << it.name();
    EXPECT_EQ(channels, 8);
    EXPECT_EQ(header.typedAttribute<Imf::StringAttribute>("rtval.scene").value(), "classic");
    EXPECT_EQ(header.typedAttribute<Imf::StringAttribute>("rtval.rays_camera").value(), "307200");
    EXPECT_EQ(
        header.typedAttribute<Imf::StringAttribute>("rtval.a_name_longer_than_thirty_one_chars")
            .value(),
        "x");

    struct Expect {
        const char* name;
        const Plane* plane;
        int stride, offset;
    };
    const Expect expected[] = {{"R", &img.rgb, 3, 0},      {"G", &img.rgb, 3, 1},
                               {"B", &img.rgb, 3, 2},      {"N.X", &img.normal, 3, 0},
                               {"N.Y", &img.normal, 3, 1}, {"N.Z", &img.normal, 3, 2},
                               {"id", &img.id, 1, 0},      {"depth", &img.depth, 1, 0}};
    for (const Expect& e : expected) {
        const std::vector<float> got = read_channel(in, e.name, w, h);
        for (std::size_t i = 0; i < got.size(); ++i) {
            const float want = (*e.plane)[e.stride * i + e.offset];
            ASSERT_EQ(std::memcmp(&got[i], &want, sizeof(float)), 0)
                << e.name << "[" << i << "]: " << got[i] << " != " << want;
        }
    }
    fs::remove(path);
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
