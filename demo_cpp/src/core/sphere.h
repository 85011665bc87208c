// The scene's only shape, with the paper's material parameters, and its ray tests (inline:
// they run for every sphere of every ray).
#pragma once

#include <cmath>
#include <optional>
#include <string>
#include <utility>

#include "core/interval.h"
#include "core/ray.h"

namespace rt {

struct Sphere {
    std::string name;
    point3 center;
    float radius = 1.0f;
    color surface_color;
    float reflection =
        0.0f;  // > 0 marks a mirror-like surface; never a weight (docs/paper-model.md)
    float transparency = 0.0f;  // > 0 marks glass
    float ior = 1.1f;
    color emission;

    bool is_light() const { return emission.x > 0 || emission.y > 0 || emission.z > 0; }
    bool is_glass() const { return !is_light() && transparency > 0; }
    // The paper's test for "shade as specular" (step 4): either flag, whatever the class.
    bool has_specular_flags() const { return transparency > 0 || reflection > 0; }
};

// The paper's geometric test, quirk Q1 included: a sphere whose centre lies behind the
// origin is missed even when the origin is inside it. Returns the paper's chosen t
// (t0, or t1 when t0 < 0), which may be negative exactly as in the original.
inline std::optional<float> intersect_paper(const point3& center, float radius2, const ray& r) {
    const vec3 l = center - r.origin;
    const float tca = dot(l, r.dir);
    if (tca < 0) return std::nullopt;  // Q1
    const float d2 = dot(l, l) - tca * tca;
    if (d2 > radius2) return std::nullopt;
    const float thc = std::sqrt(radius2 - d2);
    const float t0 = tca - thc;
    return t0 < 0 ? tca + thc : t0;
}

inline std::optional<float> intersect_paper(const Sphere& s, const ray& r) {
    return intersect_paper(s.center, s.radius * s.radius, r);
}

// Robust quadratic (Haines et al., Ray Tracing Gems ch. 7): discriminant from
// r^2 - |oc - (oc.d)d|^2 and the second root from c/q, evaluated in double: in float32,
// oc = origin - centre of a huge sphere (the floor, r = 10^4) keeps only ~1e-3 of the
// origin's position, which moved floor hits by that much and flipped shadow and horizon
// pixels against Mitsuba. Returns the nearest t in `range`. Precondition: |r.dir| = 1.
// The two roots t0 <= t1 of the robust test below, nothing where the ray misses the sphere.
inline std::optional<std::pair<double, double>> robust_roots(const Sphere& s, const ray& r) {
    const double ox = double(r.origin.x) - s.center.x, oy = double(r.origin.y) - s.center.y,
                 oz = double(r.origin.z) - s.center.z;
    const double dx = r.dir.x, dy = r.dir.y, dz = r.dir.z;
    const double b = ox * dx + oy * dy + oz * dz;
    const double px = ox - dx * b, py = oy - dy * b, pz = oz - dz * b;
    const double r2 = double(s.radius) * s.radius;
    const double disc = r2 - (px * px + py * py + pz * pz);
    if (disc < 0) return std::nullopt;
    const double c = ox * ox + oy * oy + oz * oz - r2;
    const double q = -b - std::copysign(std::sqrt(disc), b);
    double t0 = (q != 0.0) ? c / q : 0.0;
    double t1 = q;
    if (t0 > t1) std::swap(t0, t1);
    return std::pair{t0, t1};
}

inline std::optional<float> intersect_robust(const Sphere& s, const ray& r, interval range) {
    const auto roots = robust_roots(s, r);
    if (!roots) return std::nullopt;
    if (range.surrounds(float(roots->first))) return float(roots->first);
    if (range.surrounds(float(roots->second))) return float(roots->second);
    return std::nullopt;
}

}  // namespace rt
