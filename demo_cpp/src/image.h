// A rendered frame: linear float32 colour plus the AOVs the judge uses for effect masks.
#pragma once

#include <vector>

namespace rt {

struct RenderedImage {
    int width = 0;
    int height = 0;
    std::vector<float> rgb;     // 3 per pixel, row-major, y down; linear, unclamped
    std::vector<float> id;      // sphere index of the camera ray's hit, -1 on a miss
    std::vector<float> depth;   // camera-ray distance, 0 on a miss
    std::vector<float> normal;  // 3 per pixel, facing the camera, 0 on a miss

    RenderedImage() = default;
    RenderedImage(int w, int h)
        : width(w),
          height(h),
          rgb(3u * w * h),
          id(1u * w * h, -1.0f),
          depth(1u * w * h),
          normal(3u * w * h) {}
};

}  // namespace rt
