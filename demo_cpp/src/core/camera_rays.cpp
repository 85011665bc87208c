#include "core/camera_rays.h"

#include <cmath>

namespace rt {

CameraRays::CameraRays(const Camera& cam, int width, int height, CameraSlips slips)
    : origin_(cam.position),
      forward_(normalize(cam.look_at - cam.position)),
      right_(normalize(cross(forward_, cam.up))),
      up_(cross(right_, forward_)),
      half_height_(
          std::tan(cam.fov_y * (slips.full_angle_fov ? 1.0f : 0.5f) * 3.14159265358979f / 180.0f)),
      aspect_(slips.no_aspect ? 1.0f : static_cast<float>(width) / static_cast<float>(height)),
      width_(static_cast<float>(width)),
      height_(static_cast<float>(height)),
      unnormalized_(slips.unnormalized),
      map_(slips.map) {}

ray CameraRays::render_from_camera(float px, float py) const {
    float xx, yy;
    if (map_) {
        xx = (2.0f * px / width_ - 1.0f) * map_->su + map_->ou;
        yy = (1.0f - 2.0f * py / height_) * map_->sv + map_->ov;
    } else {
        xx = (2.0f * px / width_ - 1.0f) * half_height_ * aspect_;
        yy = (1.0f - 2.0f * py / height_) * half_height_;
    }
    const vec3 dir = right_ * xx + up_ * yy + forward_;
    return {origin_, unnormalized_ ? dir : normalize(dir)};
}

}  // namespace rt
