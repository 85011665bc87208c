#include "image_io.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>

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

TEST(ImageIo, LinearEncodingIsThePapersClampTimes255) {
    EXPECT_EQ(to_linear8(0.5f), 128);
    EXPECT_EQ(to_linear8(-1.0f), 0);
    EXPECT_EQ(to_linear8(7.0f), 255);
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
