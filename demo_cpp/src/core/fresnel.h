// Reflectance formulas: the paper's approximation (Q8) and the exact dielectric one.
#pragma once

#include <algorithm>
#include <cmath>

namespace rt {

// The paper's `mix(pow(1 - facing, 3), 1, 0.1)` = 0.1 + 0.9 (1 - facing)^3.
inline float paper_fresnel(float facing) {
    const float f = 1.0f - facing;
    return 0.1f + 0.9f * f * f * f;
}

// Unpolarised Fresnel reflectance of a smooth dielectric interface, as Mitsuba's fresnel():
// cos_theta_i > 0 means the ray arrives from outside; eta = interior / exterior index.
// Returns 1 at total internal reflection.
inline float dielectric_fresnel(float cos_theta_i, float eta) {
    if (eta == 1.0f) return 0.0f;
    const bool outside = cos_theta_i >= 0.0f;
    const float eta_it = outside ? eta : 1.0f / eta;
    const float eta_ti = 1.0f / eta_it;
    const float cos_i = std::fabs(cos_theta_i);
    const float cos_t_sqr = 1.0f - eta_ti * eta_ti * (1.0f - cos_i * cos_i);
    if (cos_t_sqr <= 0.0f) return 1.0f;
    const float cos_t = std::sqrt(cos_t_sqr);
    const float a_s = (cos_i - eta_it * cos_t) / (cos_i + eta_it * cos_t);
    const float a_p = (cos_t - eta_it * cos_i) / (cos_t + eta_it * cos_i);
    return std::clamp(0.5f * (a_s * a_s + a_p * a_p), 0.0f, 1.0f);
}

}  // namespace rt
