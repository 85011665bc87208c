// Test helpers shared by the EXR writers' tests: an image with distinct and awkward values in
// every channel, and a file's channels read back by OpenEXR and compared bit for bit.
#pragma once

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "io/image.h"

namespace rt::test {

inline RenderedImage sample_image(int w, int h) {
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

inline std::vector<float> read_channel(Imf::InputFile& in, const char* name, int w, int h) {
    std::vector<float> out(static_cast<std::size_t>(w) * h);
    Imf::FrameBuffer fb;
    fb.insert(name, Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(out.data()), sizeof(float),
                               sizeof(float) * static_cast<std::size_t>(w)));
    in.setFrameBuffer(fb);
    in.readPixels(0, h - 1);
    return out;
}

// Every channel of the file read back by OpenEXR (R, G, B alone without `aovs`), compared
// with the image bit for bit.
inline void expect_pixels(Imf::InputFile& in, const RenderedImage& img, bool aovs = true) {
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
        if (!aovs && e.plane != &img.rgb) continue;
        const std::vector<float> got = read_channel(in, e.name, img.width, img.height);
        for (std::size_t i = 0; i < got.size(); ++i) {
            const float want = (*e.plane)[e.stride * i + e.offset];
            ASSERT_EQ(std::memcmp(&got[i], &want, sizeof(float)), 0)
                << e.name << "[" << i << "]: " << got[i] << " != " << want;
        }
    }
}

// The file's channel names, in the order OpenEXR lists them (name order).
inline std::vector<std::string> channel_names(Imf::InputFile& in) {
    std::vector<std::string> out;
    const Imf::ChannelList& channels = in.header().channels();
    for (auto it = channels.begin(); it != channels.end(); ++it) out.emplace_back(it.name());
    return out;
}

// The image without its AOV planes, as a frame rendered for an RGB-only EXR has none.
inline RenderedImage without_aovs(RenderedImage img) {
    img.id = Plane();
    img.depth = Plane();
    img.normal = Plane();
    return img;
}

}  // namespace rt::test
