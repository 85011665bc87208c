#include "core/tracer.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/fresnel.h"
#include "core/light_units.h"
#include "core/optics.h"
#include "core/student_slips.h"

namespace rt {

namespace {
constexpr float kInf = std::numeric_limits<float>::infinity();
}

Tracer::Tracer(const Scene& scene, TraceOptions options)
    : scene_(scene),
      opt_(options),
      lanes_(scene.spheres),
      use_lanes_(opt_.quirks.has(Quirk::paper_intersection) && lanes_.usable() &&
                 !has_root_slip(opt_.mistakes)) {
    if (opt_.mistakes.has(Mistake::depth_cut)) opt_.max_depth -= 1;
    for (int i = 0; i < static_cast<int>(scene.spheres.size()); ++i) {
        if (scene.spheres[i].is_light()) {
            lights_.push_back(i);
            light_intensity_.push_back(point_intensity(scene, scene.spheres[i]));
        }
    }
}

float Tracer::offset_at(const point3& p) const {
    if (opt_.mistakes.has(Mistake::no_offset)) return 0.0f;
    if (opt_.quirks.has(Quirk::paper_intersection)) return scene_.bias;
    return scene_.bias * (1.0f + max_abs_component(p));
}

Tracer::Hit Tracer::nearest_hit(const ray& r, int skip) const {
    if (use_lanes_) return lanes_.nearest_paper(r, skip);
    Hit best{-1, kInf};
    float t_near = kInf;
    const bool paper = opt_.quirks.has(Quirk::paper_intersection);
    const bool slip = has_root_slip(opt_.mistakes);
    for (int i = 0; i < static_cast<int>(scene_.spheres.size()); ++i) {
        if (i == skip) continue;
        const Sphere& sphere = scene_.spheres[i];
        const interval range{0.0f, t_near};
        const std::optional<float> t =
            slip && paper ? intersect_with_root_slip(sphere, r, opt_.mistakes)
            : slip        ? intersect_robust_with_root_slip(sphere, r, range, opt_.mistakes)
            : paper       ? intersect_paper(sphere, r)
                          : intersect_robust(sphere, r, range);
        if (t && *t < t_near) {
            t_near = *t;
            best = Hit{i, *t};
        }
    }
    return best;
}

bool Tracer::blocks(int j, const ray& shadow_ray, float max_t) const {
    const bool paper = opt_.quirks.has(Quirk::paper_intersection);
    if (has_root_slip(opt_.mistakes) && paper) {
        const std::optional<float> t =
            intersect_with_root_slip(scene_.spheres[j], shadow_ray, opt_.mistakes);
        return t && *t < max_t;
    }
    if (has_root_slip(opt_.mistakes))
        return intersect_robust_with_root_slip(scene_.spheres[j], shadow_ray, {0.0f, max_t},
                                               opt_.mistakes)
            .has_value();
    if (paper) {
        const std::optional<float> t = intersect_paper(scene_.spheres[j], shadow_ray);
        return t && *t < max_t;
    }
    return intersect_robust(scene_.spheres[j], shadow_ray, {0.0f, max_t}).has_value();
}

namespace {
PrimaryHit primary_hit(const Scene& scene, const ray& r, int index, float t) {
    vec3 n = normalize(r.at(t) - scene.spheres[index].center);
    if (dot(r.dir, n) > 0) n = -n;
    return {index, t, n};
}
}  // namespace

PrimaryHit Tracer::primary(const ray& r) const {
    ++counts_.camera;
    const auto hit = nearest_hit(r, -1);
    return hit ? primary_hit(scene_, r, hit.index, hit.t) : PrimaryHit{};
}

color Tracer::trace(const ray& r, int depth, PrimaryHit* first) const {
    return traced(RayKind::camera, r, depth, -1, first);
}

color Tracer::traced(RayKind kind, const ray& r, int depth, int skip, PrimaryHit* first) const {
    if (!recorder_) return trace_skipping(r, depth, skip, first);
    recorder_->begin_ray(kind, r, depth);
    const color c = trace_skipping(r, depth, skip, first);
    recorder_->end_ray(c);
    return c;
}

color Tracer::trace_skipping(const ray& r, int depth, int skip, PrimaryHit* first) const {
    ++(depth == 0 ? counts_.camera : counts_.secondary);
    if (budget_.budget && out_of_budget()) return color(0.0f);  // the render is abandoned
    const auto hit = nearest_hit(r, skip);
    if (first) *first = hit ? primary_hit(scene_, r, hit.index, hit.t) : PrimaryHit{};
    if (!hit) return opt_.mistakes.has(Mistake::black_background) ? color(0.0f) : scene_.background;

    if (recorder_) recorder_->hit(hit.index, hit.t);
    const Sphere& s = scene_.spheres[hit.index];
    const bool paper_light = opt_.quirks.has(Quirk::no_pi_no_falloff);
    // Q13: the hit sphere's own light is never added; a light is shaded like any surface.
    const bool own_light = !opt_.quirks.has(Quirk::no_own_emission);
    if (!paper_light && own_light && s.is_light()) return sphere_radiance(scene_, s);

    const point3 p = r.at(hit.t);
    vec3 n =
        opt_.mistakes.has(Mistake::normal_not_normalized) ? p - s.center : normalize(p - s.center);
    bool inside = false;
    // inside_test_reversed: the student's test reads "the ray is inside when d.n < 0".
    if ((dot(r.dir, n) > 0) != opt_.mistakes.has(Mistake::inside_test_reversed)) {
        if (!opt_.mistakes.has(Mistake::no_inside_flip)) n = -n;
        inside = true;
    }
    if (opt_.mistakes.has(Mistake::flipped_normal)) n = -n;

    if (recorder_) recorder_->surface(n, inside, s.has_specular_flags() && depth >= opt_.max_depth);
    color c;
    if (s.has_specular_flags() && depth < opt_.max_depth) {
        c = shade_specular(hit.index, r, p, n, inside, depth);
    } else if (s.has_specular_flags() && !opt_.quirks.has(Quirk::diffuse_at_max_depth)) {
        c = color(0.0f);  // a specular chain cut at max_depth carries nothing, as in Mitsuba
    } else {
        c = shade_direct(hit.index, p, n);
    }
    return paper_light && own_light ? c + s.emission : c;
}

color Tracer::shade_specular(int hit_index, const ray& r, const point3& p, const vec3& n,
                             bool inside, int depth) const {
    const Sphere& s = scene_.spheres[hit_index];
    const QuirkSet& q = opt_.quirks;
    const float d_dot_n = dot(r.dir, n);
    const float facing =
        opt_.mistakes.has(Mistake::fresnel_facing_sign) ? d_dot_n : std::max(0.0f, -d_dot_n);
    const float offset = offset_at(p);

    bool total_internal = false;
    color refracted(0.0f);
    float eta_ti_sq = 1.0f;  // radiance scale across the interface (exact mode only)
    if (s.transparency > 0) {
        float eta = (q.has(Quirk::eta_one_over_ior_leaving) || !inside) ? 1.0f / s.ior : s.ior;
        if (opt_.mistakes.has(Mistake::eta_inverted)) eta = 1.0f / eta;
        if (opt_.mistakes.has(Mistake::eta_one_leaving) && inside) eta = 1.0f;
        if (opt_.mistakes.has(Mistake::eta_ior_both)) eta = s.ior;
        total_internal =
            refraction_k(r.dir, n, eta) < 0 && !q.has(Quirk::nan_at_total_internal_reflection);
        if (!total_internal && opt_.refraction)
            refracted =
                traced(RayKind::refraction,
                       {refraction_origin(p, n, offset), refracted_direction(r.dir, n, eta)},
                       depth + 1, -1);
        eta_ti_sq = eta * eta;
    }

    float fresnel;
    if (total_internal) {
        fresnel = 1.0f;
    } else if (q.has(Quirk::paper_fresnel)) {
        fresnel = paper_fresnel(facing, paper_curve(opt_));
    } else if (s.transparency > 0) {
        fresnel = dielectric_fresnel(inside ? -facing : facing, s.ior);
    } else {
        fresnel = 1.0f;  // conductor material="none": an exact mirror tinted by its colour
    }
    if (!total_internal && opt_.mistakes.has(Mistake::fresnel_constant)) fresnel = 0.5f;
    if (recorder_) recorder_->specular(fresnel, total_internal);

    color reflected(0.0f);
    if (opt_.reflection) {
        const vec3 r_dir = opt_.mistakes.has(Mistake::reflect_sign) ? reflect_wrong_sign(r.dir, n)
                                                                    : reflect(r.dir, n);
        // Leaving a convex sphere outward, the ray cannot meet it again (Q1 fixed only).
        const int skip = (!q.has(Quirk::paper_intersection) && !inside) ? hit_index : -1;
        reflected = traced(RayKind::reflection, {p + n * offset, r_dir}, depth + 1, skip);
    }
    const float t_weight = q.has(Quirk::paper_fresnel) ? 1.0f : eta_ti_sq;
    if (opt_.mistakes.has(Mistake::fresnel_missing))  // both at full strength, unmixed
        return (reflected + refracted * (s.transparency * t_weight)) * s.surface_color;
    if (has_mix_slip(opt_.mistakes))
        return mix_with_slip(opt_.mistakes, {reflected, refracted}, fresnel,
                             {s.transparency, t_weight, s.surface_color});
    return (reflected * fresnel + refracted * ((1.0f - fresnel) * s.transparency * t_weight)) *
           s.surface_color;
}

vec3 Tracer::refracted_direction(const vec3& d, const vec3& n, float eta) const {
    return opt_.mistakes.has(Mistake::cosi_sign) ? refract_cosi_sign(d, n, eta)
                                                 : refract(d, n, eta);
}

point3 Tracer::refraction_origin(const point3& p, const vec3& n, float offset) const {
    return opt_.mistakes.has(Mistake::refraction_bias_outside) ? p + n * offset : p - n * offset;
}

color Tracer::shade_direct(int hit_index, const point3& p, const vec3& n) const {
    const Sphere& s = scene_.spheres[hit_index];
    const QuirkSet& q = opt_.quirks;
    const float offset = offset_at(p);
    const point3 origin = p + n * offset;
    // The paper aims shadow rays from the hit point; with Q1 fixed, from the offset origin
    // so that the distance bound is measured from where the ray starts.
    const point3 aim_from = q.has(Quirk::paper_intersection) ? p : origin;
    float shared_shadow = 1.0f;  // Q4: one shadow factor for all lights, compounded
    // Q11: the paper's colour starts at 1 and each light is added to it.
    color c(q.has(Quirk::lit_colour_starts_at_one) ? 1.0f : 0.0f);
    const bool from_normal = opt_.mistakes.has(Mistake::light_dir_from_normal);
    for (std::size_t li = 0; li < lights_.size(); ++li) {
        const int light = lights_[li];
        const Sphere& l_sphere = scene_.spheres[light];
        // light_dir_from_normal: the normal where the hit point belongs.
        const vec3 to_light = l_sphere.center - (from_normal ? n : aim_from);
        const float dist = length(to_light);
        const vec3 l = light_direction(opt_.mistakes, to_light, dist);
        // Q12: no Lambert cosine, so a light behind the surface counts too; its shadow ray is
        // then cast like any other (under Q1 the hit sphere itself can block it).
        const float lambert = q.has(Quirk::no_lambert_cosine) ? 1.0f : std::max(0.0f, dot(n, l));
        float transmission = 1.0f;
        if (opt_.shadows && !opt_.mistakes.has(Mistake::no_shadows) &&
            (q.has(Quirk::shared_shadow_factor) || lambert > 0)) {
            ++counts_.shadow;
            const ray shadow_ray{origin, l};
            const bool first_only = opt_.mistakes.has(Mistake::shadow_first_only);
            const bool skip_glass = opt_.mistakes.has(Mistake::shadow_skips_glass);
            const float max_t = q.has(Quirk::shadow_rays_pass_light) ||
                                        opt_.mistakes.has(Mistake::shadow_past_light)
                                    ? kInf
                                    : dist;
            // With lanes, every sphere is tested at once and the blockers are walked in order.
            const std::uint64_t blockers =
                use_lanes_ ? lanes_.blockers_paper(shadow_ray, max_t) : 0;
            for (int j = 0; j < static_cast<int>(scene_.spheres.size()); ++j) {
                if (j == light && !opt_.mistakes.has(Mistake::light_blocks_itself)) continue;
                if (skip_glass && scene_.spheres[j].transparency > 0) continue;
                // Q1 fixed: a ray leaving a convex sphere outward cannot hit it again.
                if (j == hit_index && !q.has(Quirk::paper_intersection)) continue;
                const bool blocked =
                    use_lanes_ ? (blockers >> j & 1) != 0 : blocks(j, shadow_ray, max_t);
                if (!blocked && first_only) break;
                if (!blocked) continue;
                if (recorder_) recorder_->blocker(j);
                const float opacity = q.has(Quirk::glass_partial_shadow)
                                          ? 1.0f - scene_.spheres[j].transparency
                                          : 1.0f;
                if (q.has(Quirk::shared_shadow_factor)) {
                    shared_shadow = std::max(0.0f, shared_shadow - opacity);
                    transmission *= shared_shadow;
                } else {
                    transmission *= 1.0f - opacity;
                    if (transmission == 0.0f) break;
                }
                if (first_only) break;
            }
        }
        if (recorder_) recorder_->light_sample(light, l, lambert, transmission);
        // light_colour_from_hit: the light's colour read from the sphere being shaded, whose
        // emission is 0 unless it is a light itself.
        const bool from_hit = opt_.mistakes.has(Mistake::light_colour_from_hit);
        if (from_hit && !s.is_light()) continue;
        if (q.has(Quirk::no_pi_no_falloff)) {
            c += s.surface_color * (from_hit ? s.emission : l_sphere.emission) *
                 (transmission * lambert);
        } else {
            // Lambert albedo/pi times a point light's I/d^2; I = pi E d0^2 (light_units.h).
            const vec3 from_p = l_sphere.center - p;
            const float irradiance_scale = transmission * lambert / dot(from_p, from_p);
            c += s.surface_color * light_intensity_[li] * (irradiance_scale / kPi);
        }
    }
    return c;
}

}  // namespace rt
