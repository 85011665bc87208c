#include "image_io.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

namespace rt {
namespace {
namespace fs = std::filesystem;

TEST(ImageIo, SrgbEncodingOfKnownValues) {
    EXPECT_EQ(to_srgb8(0.0f), 0);
    EXPECT_EQ(to_srgb8(1.0f), 255);
    EXPECT_EQ(to_srgb8(2.0f), 255);      // clamped
    EXPECT_EQ(to_srgb8(0.5f), 188);      // 1.055 * 0.5^(1/2.4) - 0.055 = 0.7354
    EXPECT_EQ(to_srgb8(0.002f), 7);      // linear segment: 12.92 * 0.002 * 255 = 6.6
    EXPECT_EQ(to_srgb8(std::numeric_limits<float>::quiet_NaN()), 0);
}

TEST(ImageIo, LinearEncodingIsThePapersClampTimes255) {
    EXPECT_EQ(to_linear8(0.5f), 128);
    EXPECT_EQ(to_linear8(-1.0f), 0);
    EXPECT_EQ(to_linear8(7.0f), 255);
}

// write_ppm converts four values at a time: every byte must be std::lround(clamp * 255), the
// paper's rounding, including ties (x.5 after scaling), NaN, +-0, denormals and infinities.
TEST(ImageIo, PpmBytesAreThePapersRoundingForAwkwardValues) {
    std::vector<float> values = {0.5f / 255, 1.5f / 255, 254.5f / 255, 0.49999997f, 0.50000006f, -0.0f, 0.0f,
                                 1e-40f, -1e-40f, 1.0f, 0.99999994f, 1.00000012f,
                                 std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(),
                                 std::numeric_limits<float>::quiet_NaN()};
    for (int k = 0; k <= 255 * 8; ++k) values.push_back(static_cast<float>(k) / (255.0f * 8));
    for (int k = 0; k <= 255; ++k) {  // the neighbours of each tie
        const float tie = (k + 0.5f) / 255.0f;
        values.push_back(std::nextafter(tie, 0.0f));
        values.push_back(std::nextafter(tie, 1.0f));
    }
    while (values.size() % 3) values.push_back(0.25f);
    RenderedImage img(static_cast<int>(values.size() / 3), 1);
    img.rgb = values;
    const fs::path path = fs::temp_directory_path() / "rtdemo_ppm_bytes_test.ppm";
    write_ppm(path.string(), img);
    std::ifstream in(path, std::ios::binary);
    std::string magic;
    int w = 0, h = 0, maxval = 0;
    in >> magic >> w >> h >> maxval;
    in.get();
    std::vector<char> bytes(values.size());
    in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    ASSERT_TRUE(in);
    for (std::size_t i = 0; i < values.size(); ++i) {
        const float c = std::isnan(values[i]) ? 0.0f : std::fmin(1.0f, std::fmax(0.0f, values[i]));
        EXPECT_EQ(static_cast<unsigned char>(bytes[i]), static_cast<unsigned char>(std::lround(c * 255.0f)))
            << "value " << values[i];
    }
    fs::remove(path);
}

TEST(ImageIo, PpmHasHeaderAndLinearBytes) {
    RenderedImage img(2, 1);
    img.rgb = {0.5f, 0.0f, 1.0f, 2.0f, 0.25f, 0.0f};
    const fs::path path = fs::temp_directory_path() / "rtdemo_image_io_test.ppm";
    write_ppm(path.string(), img);
    std::ifstream in(path, std::ios::binary);
    std::string data((std::istreambuf_iterator<char>(in)), {});
    const std::string header = "P6\n2 1\n255\n";
    ASSERT_EQ(data.size(), header.size() + 6);
    EXPECT_EQ(data.substr(0, header.size()), header);
    EXPECT_EQ(static_cast<unsigned char>(data[header.size() + 0]), 128);
    EXPECT_EQ(static_cast<unsigned char>(data[header.size() + 3]), 255);
    EXPECT_EQ(static_cast<unsigned char>(data[header.size() + 4]), 64);
    fs::remove(path);
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
