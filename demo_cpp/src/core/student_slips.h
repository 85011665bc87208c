// Named mistakes (mistakes.h) that change one formula of the tracer: each helper below is the
// formula as a student's program writes it with that slip. The scalar tracer calls them only
// when the mistake is set; the packet engine repeats each one per lane (packet/kernels.inc),
// bit for bit (packet_engine_test.cpp).
#pragma once

#include <cmath>
#include <optional>

#include "core/camera_rays.h"
#include "core/mistakes.h"
#include "core/optics.h"
#include "core/ray.h"
#include "core/sphere.h"
#include "core/tracer.h"
#include "core/vec3.h"

namespace rt {

inline bool has_root_slip(const MistakeSet& m) {
    return m.has(Mistake::near_root_only) || m.has(Mistake::negative_root_hit) ||
           m.has(Mistake::far_root);
}

// The paper's geometric test, with a slip at its last line: near_root_only misses the sphere
// when t0 < 0 (a ray inside never leaves), negative_root_hit keeps a negative t0, far_root
// always takes t1.
inline std::optional<float> intersect_with_root_slip(const Sphere& s, const ray& r,
                                                     const MistakeSet& m) {
    const vec3 l = s.center - r.origin;
    const float tca = dot(l, r.dir);
    if (tca < 0) return std::nullopt;
    const float d2 = dot(l, l) - tca * tca;
    const float radius2 = s.radius * s.radius;
    if (d2 > radius2) return std::nullopt;
    const float thc = std::sqrt(radius2 - d2);
    const float t0 = tca - thc;
    if (m.has(Mistake::far_root)) return tca + thc;
    if (t0 >= 0 || m.has(Mistake::negative_root_hit)) return t0;
    if (m.has(Mistake::near_root_only)) return std::nullopt;
    return tca + thc;
}

// The robust test (quirk Q1 fixed) with the same slips: near_root_only misses the sphere
// when t0 lies before the range, negative_root_hit takes a t0 behind the origin, far_root
// takes t1 alone.
inline std::optional<float> intersect_robust_with_root_slip(const Sphere& s, const ray& r,
                                                            interval range, const MistakeSet& m) {
    const auto roots = robust_roots(s, r);
    if (!roots) return std::nullopt;
    const float t0 = float(roots->first), t1 = float(roots->second);
    if (m.has(Mistake::far_root))
        return range.surrounds(t1) ? std::optional<float>(t1) : std::nullopt;
    if (range.surrounds(t0)) return t0;
    if (t0 <= range.min && m.has(Mistake::negative_root_hit)) return t0;
    if (t0 <= range.min && m.has(Mistake::near_root_only)) return std::nullopt;
    if (range.surrounds(t1)) return t1;
    return std::nullopt;
}

// reflect_sign: d + 2(d.n)n, the mirror formula with its sign turned.
inline vec3 reflect_wrong_sign(const vec3& d, const vec3& n) {
    return normalize(d + n * (2.0f * dot(d, n)));
}

// cosi_sign: the refracted direction with cos i taken as +n.d (k, which squares it, is the
// same).
inline vec3 refract_cosi_sign(const vec3& d, const vec3& n, float eta) {
    const float cosi = dot(n, d);
    return normalize(d * eta + n * (eta * cosi - std::sqrt(refraction_k(d, n, eta))));
}

// The direction towards the light (to_light / dist), or as light_dir_reversed and
// shadow_dir_unnormalized write it.
inline vec3 light_direction(const MistakeSet& m, const vec3& to_light, float dist) {
    const vec3 l = m.has(Mistake::shadow_dir_unnormalized) ? to_light : to_light / dist;
    return m.has(Mistake::light_dir_reversed) ? -l : l;
}

inline bool has_mix_slip(const MistakeSet& m) {
    return m.has(Mistake::reflection_untinted) || m.has(Mistake::fresnel_weights_swapped) ||
           m.has(Mistake::refraction_unweighted);
}

struct SpecularParts {
    color reflected, refracted;
};

struct MixWeights {
    float transparency, t_weight;
    color tint;  // the surface colour
};

// The specular mix with reflection_untinted (the tint on the refracted part only),
// fresnel_weights_swapped and refraction_unweighted (no transparency factor).
inline color mix_with_slip(const MistakeSet& m, SpecularParts parts, float fresnel, MixWeights w) {
    const bool swapped = m.has(Mistake::fresnel_weights_swapped);
    const float f_reflect = swapped ? 1.0f - fresnel : fresnel;
    const float f_refract = swapped ? fresnel : 1.0f - fresnel;
    const float transparency = m.has(Mistake::refraction_unweighted) ? 1.0f : w.transparency;
    const float refract_weight = f_refract * transparency * w.t_weight;
    if (m.has(Mistake::reflection_untinted))
        return parts.reflected * f_reflect + parts.refracted * refract_weight * w.tint;
    return (parts.reflected * f_reflect + parts.refracted * refract_weight) * w.tint;
}

// The camera slips (camera_rays.h) the named camera mistakes and a camera map set.
inline CameraSlips camera_slips(const TraceOptions& t) {
    const MistakeSet& m = t.mistakes;
    return {m.has(Mistake::aspect_ratio_missing), m.has(Mistake::fov_full_angle),
            m.has(Mistake::ray_dir_unnormalized), t.camera_map};
}

}  // namespace rt
