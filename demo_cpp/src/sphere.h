// The scene's only shape, with the paper's material parameters.
#pragma once

#include <optional>
#include <string>

#include "interval.h"
#include "ray.h"

namespace rt {

struct Sphere {
    std::string name;
    point3 center;
    float radius = 1.0f;
    color surface_color;
    float reflection = 0.0f;    // > 0 marks a mirror-like surface; never a weight (paper-model.md)
    float transparency = 0.0f;  // > 0 marks glass
    float ior = 1.1f;
    color emission;

    bool is_light() const { return emission.x > 0 || emission.y > 0 || emission.z > 0; }
    bool is_glass() const { return !is_light() && transparency > 0; }
    bool is_mirror() const { return !is_light() && !is_glass() && reflection > 0; }
    // The paper's test for "shade as specular" (step 4): either flag, whatever the class.
    bool has_specular_flags() const { return transparency > 0 || reflection > 0; }
};

// The paper's geometric test, quirk Q1 included: a sphere whose centre lies behind the
// origin is missed even when the origin is inside it. Returns the paper's chosen t
// (t0, or t1 when t0 < 0), which may be negative exactly as in the original.
std::optional<float> intersect_paper(const Sphere& s, const ray& r);

// Robust quadratic (Haines et al., Ray Tracing Gems ch. 7): discriminant from
// r^2 - |oc - (oc.d)d|^2 and the second root from c/q. Returns the nearest t in `range`.
// Precondition: r.dir is unit length.
std::optional<float> intersect_robust(const Sphere& s, const ray& r, interval range);

}  // namespace rt
