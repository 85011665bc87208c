// Mirror and refraction directions, as the paper writes them.
#pragma once

#include <cmath>

#include "core/vec3.h"

namespace rt {

// Mirror direction of d about n (n faces the incoming ray).
inline vec3 reflect(const vec3& d, const vec3& n) { return normalize(d - n * (2.0f * dot(d, n))); }

// 1 - eta^2 (1 - cos_i^2): negative means total internal reflection.
inline float refraction_k(const vec3& d, const vec3& n, float eta) {
    const float cosi = -dot(n, d);
    return 1.0f - eta * eta * (1.0f - cosi * cosi);
}

// Refracted direction for relative index eta = n_from / n_to, n facing the incoming ray.
// With k < 0 this is NaN, exactly like the original's sqrt(k) (quirk Q3).
inline vec3 refract(const vec3& d, const vec3& n, float eta) {
    const float cosi = -dot(n, d);
    return normalize(d * eta + n * (eta * cosi - std::sqrt(refraction_k(d, n, eta))));
}

}  // namespace rt
