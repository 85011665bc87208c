// Reflectance formulas: the paper's approximation (Q8) and the exact dielectric one.
#pragma once

#include <algorithm>
#include <cmath>

namespace rt {

// The paper's curve `mix(pow(1 - facing, 3), 1, 0.1)` = mix + (1 - mix) (1 - facing)^power,
// with the two numbers a student may type otherwise (rtdemo --fresnel-mix, --fresnel-power).
struct FresnelCurve {
    float mix = 0.1f;
    int power = 3;
    bool is_papers() const { return mix == 0.1f && power == 3; }
};

// The product left to right, (1 - mix) * f * f * f, as the paper's expression rounds it.
inline float paper_fresnel(float facing, FresnelCurve c = {}) {
    const float f = 1.0f - facing;
    float rise = 1.0f - c.mix;
    for (int i = 0; i < c.power; ++i) rise *= f;
    return c.mix + rise;
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
