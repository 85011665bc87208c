// One scene as `docs/scene-format.md` defines it (rtval-scene/1).
#pragma once

#include <string>
#include <vector>

#include "core/sphere.h"

namespace rt {

struct Camera {
    point3 position{0, 0, 0};
    point3 look_at{0, 0, -1};
    vec3 up{0, 1, 0};
    float fov_y = 30.0f;  // vertical, degrees
    int width = 640;
    int height = 480;
};

struct Scene {
    std::string name;
    std::string description;
    Camera camera;
    color background{2, 2, 2};
    int max_depth = 5;
    float bias = 1e-4f;
    std::vector<Sphere> spheres;
};

}  // namespace rt
