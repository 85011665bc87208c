#include "core/camera_rays.h"

#include <cmath>

namespace rt {

CameraRays::CameraRays(const Camera& cam, int width, int height)
    : origin_(cam.position),
      forward_(normalize(cam.look_at - cam.position)),
      right_(normalize(cross(forward_, cam.up))),
      up_(cross(right_, forward_)),
      half_height_(std::tan(cam.fov_y * 0.5f * 3.14159265358979f / 180.0f)),
      aspect_(static_cast<float>(width) / static_cast<float>(height)),
      width_(static_cast<float>(width)),
      height_(static_cast<float>(height)) {}

ray CameraRays::render_from_camera(float px, float py) const {
    const float xx = (2.0f * px / width_ - 1.0f) * half_height_ * aspect_;
    const float yy = (1.0f - 2.0f * py / height_) * half_height_;
    return {origin_, normalize(right_ * xx + up_ * yy + forward_)};
}

}  // namespace rt
