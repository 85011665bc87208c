// A rendered frame: linear float32 colour plus the AOVs the judge uses for effect masks.
#pragma once

#include <cstddef>

namespace rt {

// A plane of floats. Large planes are mapped straight from the kernel in whole 2 MB pages
// (transparent huge pages) and come zero-filled: a 640x480 frame's colour then costs two page
// faults instead of ~900, and no second pass to zero it (bench/NOTES.md).
class Plane {
public:
    Plane() = default;
    explicit Plane(std::size_t n, float value = 0.0f);
    Plane(const Plane& other);
    Plane(Plane&& other) noexcept;
    Plane& operator=(Plane other) noexcept;
    ~Plane();

    float* data() { return data_; }
    const float* data() const { return data_; }
    std::size_t size() const { return size_; }
    bool empty() const { return size_ == 0; }
    float& operator[](std::size_t i) { return data_[i]; }
    const float& operator[](std::size_t i) const { return data_[i]; }
    float* begin() { return data_; }
    float* end() { return data_ + size_; }
    const float* begin() const { return data_; }
    const float* end() const { return data_ + size_; }
    friend bool operator==(const Plane& a, const Plane& b);
    friend bool operator!=(const Plane& a, const Plane& b) { return !(a == b); }

private:
    float* data_ = nullptr;
    std::size_t size_ = 0;
    std::size_t mapped_ = 0;  // bytes mapped, 0 when data_ came from the heap
};

struct RenderedImage {
    int width = 0;
    int height = 0;
    Plane rgb;     // 3 per pixel, row-major, y down; linear, unclamped
    Plane id;      // sphere index of the camera ray's hit, -1 on a miss
    Plane depth;   // camera-ray distance, 0 on a miss
    Plane normal;  // 3 per pixel, facing the camera, 0 on a miss
    Plane path;    // path-class bits (core/ray_tree.h) as floats; empty unless asked for

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
