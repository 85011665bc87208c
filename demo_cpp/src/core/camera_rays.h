// Camera ray generation exactly as docs/paper-model.md defines it (vertical fov, y down).
#pragma once

#include <optional>

#include "core/ray.h"
#include "core/scene.h"

namespace rt {

// Camera slips students make (named mistakes): the ray through a pixel computed without the
// aspect ratio, with tan(fov) for tan(fov / 2), or left unnormalised.
// Any camera a pixel loop's slip makes, fitted by the diagnosis (rtdemo --camera-map): the
// ray through (px, py) is forward + right * u + up * v with u = su (2 px / W - 1) + ou and
// v = sv (1 - 2 py / H) + ov. The scene's camera is su = tan(fov / 2) W / H, sv = tan(fov / 2),
// ou = ov = 0; a field of view taken as the horizontal one, a missing aspect ratio, a row
// divided by the width or pixel corners for centres are each other numbers.
struct CameraMap {
    float su, ou, sv, ov;
};

struct CameraSlips {
    bool no_aspect = false;
    bool full_angle_fov = false;
    bool unnormalized = false;
    std::optional<CameraMap> map;  // instead of the fov and aspect (the slips above ignored)
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
    std::optional<CameraMap> map_;
};

}  // namespace rt
