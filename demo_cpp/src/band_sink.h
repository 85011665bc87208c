// A frame handed over band by band as it renders, for outputs written while the frame is still
// being traced (image_io.h's streams): no whole frame is ever kept, so no frame-sized memory is
// page-faulted and zero-filled by the kernel first (bench/NOTES.md, issue 20).
#pragma once

namespace rt {

class BandSink {
public:
    virtual ~BandSink() = default;
    // Rows [y0, y0 + rows) of a frame `width` pixels wide, each row `width` pixels: rgb
    // interleaved (3 floats a pixel, linear, unclamped); id, depth and normal (3 floats a pixel)
    // as RenderedImage has them, or null when the frame was rendered without AOVs. Called from
    // the render threads at once, never twice for a row. Must not throw: a sink keeps its
    // failure and reports it when it is finished.
    virtual void band(int y0, int rows, int width, const float* rgb, const float* id,
                      const float* depth, const float* normal) noexcept = 0;
};

}  // namespace rt
