#include "sphere.h"

#include <cmath>
#include <utility>

namespace rt {

std::optional<float> intersect_paper(const Sphere& s, const ray& r) {
    const vec3 l = s.center - r.origin;
    const float tca = dot(l, r.dir);
    if (tca < 0) return std::nullopt;  // Q1
    const float d2 = dot(l, l) - tca * tca;
    const float r2 = s.radius * s.radius;
    if (d2 > r2) return std::nullopt;
    const float thc = std::sqrt(r2 - d2);
    const float t0 = tca - thc;
    return t0 < 0 ? tca + thc : t0;
}

std::optional<float> intersect_robust(const Sphere& s, const ray& r, interval range) {
    const vec3 oc = r.origin - s.center;
    const float b = dot(oc, r.dir);
    const vec3 perpendicular = oc - r.dir * b;
    const float r2 = s.radius * s.radius;
    const float disc = r2 - dot(perpendicular, perpendicular);
    if (disc < 0) return std::nullopt;
    const float c = dot(oc, oc) - r2;
    const float q = -b - std::copysign(std::sqrt(disc), b);
    float t0 = (q != 0.0f) ? c / q : 0.0f;
    float t1 = q;
    if (t0 > t1) std::swap(t0, t1);
    if (range.surrounds(t0)) return t0;
    if (range.surrounds(t1)) return t1;
    return std::nullopt;
}

}  // namespace rt
