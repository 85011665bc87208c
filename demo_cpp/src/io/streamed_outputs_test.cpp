// The streamed outputs against the writers of whole frames: the same PPM bytes, and an EXR that
// OpenEXR reads back bit for bit with the final attributes, whatever order and threads the
// bands arrive in; a stream never finished leaves no file.
#include "io/streamed_outputs.h"

#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfStringAttribute.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "core/cpu_renderer.h"
#include "io/exr_test_support.h"
#include "io/image_io.h"
#include "io/scene_loader.h"
#include "packet/packet_engine.h"

namespace rt {
namespace {
namespace fs = std::filesystem;
using test::expect_pixels;
using test::sample_image;

// `img`'s channels, each a plane of its own (BandPixels with step 1).
struct Planes {
    std::vector<float> c[8];  // r g b id depth n.x n.y n.z
    explicit Planes(const RenderedImage& img) {
        const std::size_t n = static_cast<std::size_t>(img.width) * img.height;
        for (std::size_t i = 0; i < n; ++i) {
            for (int k = 0; k < 3; ++k) c[k].push_back(img.rgb[3 * i + k]);
            c[3].push_back(img.id[i]);
            c[4].push_back(img.depth[i]);
            for (int k = 0; k < 3; ++k) c[5 + k].push_back(img.normal[3 * i + k]);
        }
    }
    BandPixels at(std::size_t first) const {
        return {c[0].data() + first, c[1].data() + first, c[2].data() + first,
                c[3].data() + first, c[4].data() + first, c[5].data() + first,
                c[6].data() + first, c[7].data() + first, 1};
    }
};

// Hands `img` to `sink` in bands of `rows` rows, last band first, from two threads; as planes
// when `planar`, else interleaved as RenderedImage has it.
void feed(const RenderedImage& img, int rows, BandSink& sink, bool planar = false) {
    const std::size_t w = static_cast<std::size_t>(img.width);
    const Planes planes(img);
    std::vector<int> starts;
    for (int y = 0; y < img.height; y += rows) starts.push_back(y);
    std::reverse(starts.begin(), starts.end());
    auto part = [&](std::size_t from) {
        for (std::size_t i = from; i < starts.size(); i += 2) {
            const int y0 = starts[i];
            const std::size_t first = static_cast<std::size_t>(y0) * w;
            sink.band(y0, std::min(rows, img.height - y0), img.width,
                      planar ? planes.at(first)
                             : interleaved_pixels(img.rgb.data() + 3 * first, img.id.data() + first,
                                                  img.depth.data() + first,
                                                  img.normal.data() + 3 * first));
        }
    };
    std::thread other(part, 1);
    part(0);
    other.join();
}

std::string bytes_of(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Names of this process's own (tests of two builds may run at once on one machine).
fs::path temp_path(const std::string& name) {
    return fs::temp_directory_path() / (std::to_string(::getpid()) + "_" + name);
}

TEST(StreamedOutputs, PpmIsWritePpmsFileInBothRoundings) {
    const RenderedImage img = sample_image(37, 21);
    for (PpmRounding rounding : {PpmRounding::truncate, PpmRounding::round}) {
        const fs::path whole = temp_path("rtdemo_stream_whole.ppm");
        const fs::path streamed = temp_path("rtdemo_stream_bands.ppm");
        write_ppm(whole.string(), img, rounding);
        PpmStream stream(streamed.string(), img.width, img.height, rounding);
        feed(img, 8, stream);
        stream.finish();
        EXPECT_EQ(bytes_of(streamed), bytes_of(whole));
        fs::remove(whole);
        fs::remove(streamed);
    }
}

TEST(StreamedOutputs, ExrReadsBackBitForBitWithTheFinalAttributes) {
    const int w = 37, h = 21;
    const RenderedImage img = sample_image(w, h);
    const fs::path path = temp_path("rtdemo_stream.exr");
    ExrStream stream(path.string(), w, h, {{"rtval.render_seconds", "0"}, {"rtval.scene", "s"}});
    feed(img, 5, stream);
    const std::map<std::string, std::string> final_attributes = {
        {"rtval.render_seconds", "0.012345678"}, {"rtval.scene", "s"}, {"rtval.rays", "1578329"}};
    stream.finish(final_attributes);

    Imf::InputFile in(path.c_str());
    for (const auto& [key, value] : final_attributes)
        EXPECT_EQ(in.header().typedAttribute<Imf::StringAttribute>(key).value(), value) << key;
    const std::string padding =
        in.header().typedAttribute<Imf::StringAttribute>("rtval.padding").value();
    EXPECT_EQ(padding.find_first_not_of(' '), std::string::npos);
    expect_pixels(in, img);
    fs::remove(path);
}

// --exr-channels rgb streamed (the bands' AOVs left out): the bytes write_exr writes for the
// frame without them and the same header.
TEST(StreamedOutputs, TheColourAloneStreamsAsWrittenWhole) {
    const RenderedImage full = sample_image(37, 21);
    const RenderedImage img = test::without_aovs(full);
    const fs::path streamed = temp_path("rtdemo_stream_rgb.exr");
    const fs::path whole = temp_path("rtdemo_whole_rgb.exr");
    const std::map<std::string, std::string> attributes = {{"rtval.scene", "s"}};
    ExrStream stream(streamed.string(), img.width, img.height, attributes, ExrChannels::rgb);
    feed(full, 5, stream);
    stream.finish(attributes);
    {
        Imf::InputFile in(streamed.c_str());
        EXPECT_EQ(test::channel_names(in), (std::vector<std::string>{"B", "G", "R"}));
        expect_pixels(in, img, false);
        const std::size_t padding =
            in.header().typedAttribute<Imf::StringAttribute>("rtval.padding").value().size();
        write_exr(whole.string(), img,
                  {{"rtval.scene", "s"}, {"rtval.padding", std::string(padding, ' ')}},
                  ExrCompression::none, 1, ExrChannels::rgb);
    }
    EXPECT_EQ(bytes_of(streamed), bytes_of(whole));
    fs::remove(streamed);
    fs::remove(whole);
}

// The engine hands each sink the layout it asks for (BandSink::step); both take either.
TEST(StreamedOutputs, PlanarAndInterleavedBandsWriteTheSameFiles) {
    const RenderedImage img = sample_image(37, 21);
    std::string files[2][2];  // [planar][ppm, exr]
    for (bool planar : {false, true}) {
        const fs::path ppm = temp_path("rtdemo_stream_layout.ppm");
        const fs::path exr = temp_path("rtdemo_stream_layout.exr");
        PpmStream ppm_stream(ppm.string(), img.width, img.height, PpmRounding::round);
        feed(img, 8, ppm_stream, planar);
        ppm_stream.finish();
        ExrStream exr_stream(exr.string(), img.width, img.height, {{"rtval.scene", "s"}});
        feed(img, 5, exr_stream, planar);
        exr_stream.finish({{"rtval.scene", "s"}});
        files[planar][0] = bytes_of(ppm);
        files[planar][1] = bytes_of(exr);
        fs::remove(ppm);
        fs::remove(exr);
    }
    EXPECT_EQ(files[1][0], files[0][0]);
    EXPECT_EQ(files[1][1], files[0][1]);
    EXPECT_GT(files[0][1].size(), 37u * 21u * 32u);
}

// The values known only after rendering at their longest: a time and three 64-bit ray counts
// where the provisional header had one digit each.
TEST(StreamedOutputs, TheHeaderRoomHoldsTheLongestFinalValues) {
    const fs::path path = temp_path("rtdemo_stream_room.exr");
    const std::map<std::string, std::string> provisional = {{"rtval.render_seconds", "0"},
                                                            {"rtval.rays_camera", "0"},
                                                            {"rtval.rays_secondary", "0"},
                                                            {"rtval.rays_shadow", "0"}};
    std::map<std::string, std::string> final_attributes = provisional;
    final_attributes["rtval.render_seconds"] = "1.234567e-05";
    for (const char* key : {"rtval.rays_camera", "rtval.rays_secondary", "rtval.rays_shadow"})
        final_attributes[key] = "18446744073709551615";
    ExrStream stream(path.string(), 4, 4, provisional);
    feed(sample_image(4, 4), 8, stream);
    stream.finish(final_attributes);
    Imf::InputFile in(path.c_str());
    EXPECT_EQ(in.header().typedAttribute<Imf::StringAttribute>("rtval.rays_shadow").value(),
              "18446744073709551615");
    fs::remove(path);
}

TEST(StreamedOutputs, AHeaderOutgrowingItsRoomIsAnErrorAndLeavesNoFile) {
    const fs::path path = temp_path("rtdemo_stream_long.exr");
    fs::remove(path);
    {
        ExrStream stream(path.string(), 4, 4, {{"rtval.note", "x"}});
        feed(sample_image(4, 4), 8, stream);
        EXPECT_THROW(stream.finish({{"rtval.note", std::string(ExrStream::kSlack + 2, 'x')}}),
                     OutputError);
    }
    EXPECT_FALSE(fs::exists(path));
    for (const auto& entry : fs::directory_iterator(fs::temp_directory_path()))
        EXPECT_EQ(entry.path().filename().string().rfind(path.filename().string() + ".tmp", 0),
                  std::string::npos);
}

TEST(StreamedOutputs, AnUnfinishedStreamLeavesNoFileAndABadPathIsNamed) {
    const fs::path path = temp_path("rtdemo_stream_unfinished.ppm");
    fs::remove(path);
    {
        PpmStream stream(path.string(), 4, 4, PpmRounding::truncate);
        feed(sample_image(4, 4), 2, stream);
    }
    EXPECT_FALSE(fs::exists(path));
    try {
        PpmStream stream("/nonexistent-dir/x.ppm", 4, 4, PpmRounding::truncate);
        ADD_FAILURE() << "no error";
    } catch (const OutputError& e) {
        EXPECT_NE(std::string(e.what()).find("/nonexistent-dir/x.ppm"), std::string::npos);
    }
}

// The packet engine into a stream: the bytes write_ppm writes from the frame it returns, at a
// size whose last band and tiles are partial, in both roundings and on every instruction set
// (without AOVs the PPM stream takes bytes the render threads encoded); then the EXR with AOVs.
TEST(StreamedOutputs, ThePacketEnginesBandsMakeTheSameFiles) {
    const Scene scene = load_scene_file(RTVAL_SCENES_DIR "/classic.json");
    RenderSettings settings;
    settings.width = 67;
    settings.height = 37;
    settings.threads = 2;
    settings.aovs = false;
    const fs::path whole = temp_path("rtdemo_engine_whole.ppm");
    const fs::path streamed = temp_path("rtdemo_engine_bands.ppm");
    ASSERT_TRUE(renders_in_bands(settings));
    for (Isa isa : {Isa::scalar, Isa::avx2, Isa::avx512}) {
        if (!supported(isa)) continue;
        for (PpmRounding rounding : {PpmRounding::truncate, PpmRounding::round}) {
            SCOPED_TRACE(std::string(isa_name(isa)) +
                         (rounding == PpmRounding::round ? " round" : " truncate"));
            RayCounts streamed_rays, whole_rays;
            write_ppm(whole.string(), render_packet(scene, settings, isa, &whole_rays), rounding);
            PpmStream stream(streamed.string(), settings.width, settings.height, rounding);
            render_packet(scene, settings, isa, stream, &streamed_rays);
            stream.finish();
            EXPECT_EQ(bytes_of(streamed), bytes_of(whole));
            EXPECT_EQ(streamed_rays.total(), whole_rays.total());
        }
    }

    settings.aovs = true;
    const RenderedImage frame = render_cpu(scene, settings);
    const fs::path exr = temp_path("rtdemo_engine_bands.exr");
    ExrStream exr_stream(exr.string(), settings.width, settings.height, {});
    render_cpu(scene, settings, exr_stream);
    exr_stream.finish({});
    Imf::InputFile in(exr.c_str());
    expect_pixels(in, frame);
    for (const fs::path& p : {whole, streamed, exr}) fs::remove(p);
}

}  // namespace
}  // namespace rt
