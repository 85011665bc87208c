// Camera ray generation exactly as docs/paper-model.md defines it (vertical fov, y down).
#pragma once

#include "core/ray.h"
#include "core/scene.h"

namespace rt {

// Camera slips students make (named mistakes): the ray through a pixel computed without the
// aspect ratio, with tan(fov) for tan(fov / 2), or left unnormalised.
struct CameraSlips {
    bool no_aspect = false;
    bool full_angle_fov = false;
    bool unnormalized = false;
};

class CameraRays {
public:
    CameraRays(const Camera& cam, int width, int height, CameraSlips slips = {});
    // (px, py) in continuous pixel coordinates: the centre of pixel (x, y) is (x+0.5, y+0.5).
    ray render_from_camera(float px, float py) const;

private:
    point3 origin_;
    vec3 forward_, right_, up_;
    float half_height_;  // tan(fov_y / 2)
    float aspect_;
    float width_, height_;
    bool unnormalized_;
};

}  // namespace rt
