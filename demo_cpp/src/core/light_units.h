// The light-units rule shared with the Mitsuba exporter: the paper's emission E
// has no 1/pi and no falloff, so a point light at the sphere's centre gets intensity
// I = pi * E * d0^2, with d0 the distance from the light's centre to the camera's look_at.
// A white Lambertian surface facing the light at look_at then receives the paper's E.
// The light sphere itself is seen with radiance I / (pi R^2).
#pragma once

#include <algorithm>

#include "core/scene.h"

namespace rt {

constexpr float kPi = 3.14159265358979f;

// d0^2; when look_at lies inside the light sphere, d0 is taken as the radius.
inline float calibration_distance_sq(const Scene& scene, const Sphere& light) {
    const vec3 d = light.center - scene.camera.look_at;
    return std::max(dot(d, d), light.radius * light.radius);
}

inline color point_intensity(const Scene& scene, const Sphere& light) {
    return light.emission * (kPi * calibration_distance_sq(scene, light));
}

inline color sphere_radiance(const Scene& scene, const Sphere& light) {
    return point_intensity(scene, light) / (kPi * light.radius * light.radius);
}

}  // namespace rt
