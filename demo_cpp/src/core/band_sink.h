// A frame handed over band by band as it renders, for outputs written while the frame is still
// being traced (image_io.h's streams): no whole frame is ever kept, so no frame-sized memory is
// page-faulted and zero-filled by the kernel first (bench/NOTES.md).
#pragma once

#include <optional>

#include "io/ppm_rounding.h"

namespace rt {

// A band's pixels, row after row (row stride: the frame's width). Each channel starts at its
// own pointer, `step` floats from one pixel to the next: 3 where rgb and the normal are
// interleaved as RenderedImage has them (g = r + 1, b = r + 2, likewise n.y and n.z), 1 where
// every channel is a plane of its own. Colour is linear and unclamped; the AOVs (id, depth, the
// normal) are null when the frame was rendered without them.
// For a sink that asked for it (BandSink::rgb8), the colour may come as that output's bytes
// instead: `rgb8` r g b per pixel (row stride 3 * width bytes, `step` 3), r, g and b then null.
struct BandPixels {
    const float *r, *g, *b, *id, *depth, *nx, *ny, *nz;
    int step;
    const unsigned char* rgb8 = nullptr;
    const float* path = nullptr;  // the path-class AOV (ExrChannels::*_path), whole frames only
};

class BandSink {
public:
    virtual ~BandSink() = default;
    // The layout the sink writes from fastest (BandPixels::step); it takes either.
    virtual int step() const { return 3; }
    // An 8-bit output: the rounding its bytes are made with (image_io.h to_linear8). A frame
    // without AOVs then hands over each band's colour already encoded by the render threads
    // (BandPixels::rgb8), instead of floats for the sink to encode.
    virtual std::optional<PpmRounding> rgb8() const { return std::nullopt; }
    // Rows [y0, y0 + rows) of a frame `width` pixels wide. Called from the render threads at
    // once, never twice for a row. Must not throw: a sink keeps its failure and reports it
    // when it is finished.
    virtual void band(int y0, int rows, int width, const BandPixels& pixels) noexcept = 0;
};

// RenderedImage-style planes (rgb and normal interleaved) as BandPixels.
inline BandPixels interleaved_pixels(const float* rgb, const float* id, const float* depth,
                                     const float* normal) {
    return {rgb,
            rgb + 1,
            rgb + 2,
            id,
            depth,
            normal,
            normal ? normal + 1 : nullptr,
            normal ? normal + 2 : nullptr,
            3};
}

}  // namespace rt
