// The paper's tracer (docs/paper-model.md) as a fragment shader: the GLSL twin of tracer.cpp.
// gl_program.cpp prepends `#version` and the specialisation: QUIRKS (bit q-1: quirk Qq
// present), EFFECTS (bit 0 shadows, 1 reflection, 2 refraction), MAX_DEPTH, STACK_SIZE
// (= max(MAX_DEPTH, 1)), SPHERE_COUNT, LIGHT_COUNT and LIGHT_INDICES, BIAS, BACKGROUND,
// MISTAKES_LO, MISTAKES_HI (bit m of the 64: named mistake m of mistakes.json present,
// M_<name> = m), EXACT_ARITHMETIC
// (below) and for small scenes SCENE_SPHERES (the spheres as constants). Constant switches
// let the compiler drop every path the options rule out and unroll the sphere loops: a
// mistake not set costs nothing.
//
// Written for llvmpipe (Mesa's CPU driver, 8 lanes per SIMD instruction), where most of a
// frame goes, and measured there (bench/NOTES.md): an `if` does not skip its body when no
// lane takes it, it only masks the writes, so every statement in the walk's loop costs on
// every step; only a loop ends early, once all its lanes are done. Hence the walk is
// straight-line selects, one ray per step; uniforms are read lane by lane (a gather), so
// the scene's values are constants and the view comes in as flat inputs.
//
// GLSL has no recursion. A pixel's colour is linear in its children's colours
// (c = local + wR * c_reflected + wT * c_refracted), so a depth-first walk over rays with
// weights, summing weight * local, gives the same value. The walk follows each reflected ray
// at once and stacks the refracted one; along a chain depths rise, so the stack holds at
// most one ray per depth: MAX_DEPTH entries suffice.

layout(location = 0) out vec4 out_color;   // linear RGB (or display-encoded in the window)
layout(location = 1) out vec4 out_aov;     // id, depth
layout(location = 2) out vec4 out_normal;  // N facing the camera

struct Sphere {
    vec4 center_radius;
    vec4 color_reflection;
    vec4 emission_transparency;
    vec4 ior;               // x: ior
    vec4 light_intensity;   // xyz: I = pi E d0^2 (light_units.h), w: 1 for a light
};
#ifdef SCENE_SPHERES
const Sphere spheres[SPHERE_COUNT] = Sphere[SPHERE_COUNT](SCENE_SPHERES);
#else
layout(std430, binding = 0) readonly buffer Spheres { Sphere spheres[]; };
#endif

// The sphere a lane hit. With constant spheres, a chain of selects over them (each lane's
// index differs) instead of a per-lane load from the constant array.
Sphere sphere_at(int i) {
#ifdef SCENE_SPHERES
    Sphere s = spheres[0];
    for (int k = 1; k < SPHERE_COUNT; ++k)
        if (i == k) s = spheres[k];
    return s;
#else
    return spheres[max(i, 0)];
#endif
}

#if LIGHT_COUNT > 0
const int LIGHTS[LIGHT_COUNT] = int[LIGHT_COUNT](LIGHT_INDICES);
#endif

// The view, from the vertex shader (fullscreen.vert.glsl).
flat in vec3 cam_origin;
flat in vec3 cam_forward;
flat in vec3 cam_right;
flat in vec3 cam_up;
flat in float half_height;
flat in vec2 size;
flat in int strata;
flat in int display;

// The CPU's arithmetic to the last bit where an image depends on it (EXACT_ARITHMETIC, set
// by gl_program.cpp for no_offset and reflect_sign): a ray that starts exactly on a surface,
// or heads into it, hits it again or not by the last bit of its origin, so one rounding apart
// is a different pixel (measured: 5 to 12 % of pixels off with GLSL's own dot and normalize,
// which may fuse multiply-adds and take a reciprocal square root). These are vec3.h's: left
// to right, unfused (precise), a true square root and division. Otherwise the built-ins.
#ifdef EXACT_ARITHMETIC
float dot3(vec3 a, vec3 b) {
    precise float r = a.x * b.x + a.y * b.y + a.z * b.z;
    return r;
}
double dot3(dvec3 a, dvec3 b) {
    precise double r = a.x * b.x + a.y * b.y + a.z * b.z;
    return r;
}
vec3 unit(vec3 v) {
    precise float len = sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
    precise vec3 r = v / len;
    return r;
}
#else
float dot3(vec3 a, vec3 b) { return dot(a, b); }
double dot3(dvec3 a, dvec3 b) { return dot(a, b); }
vec3 unit(vec3 v) { return normalize(v); }
#endif
const float PI = 3.14159265358979;
const float INF = uintBitsToFloat(0x7F800000u);

bool quirk(int q) { return (QUIRKS & (1 << (q - 1))) != 0; }
bool effect(int bit) { return (EFFECTS & (1 << bit)) != 0; }
// A named student mistake (compare/diagnose/mistakes.json), each written where the CPU
// tracer has it (tracer.cpp, student_slips.h, camera_rays.cpp).
bool mistake(int m) {
    uint half_mask = m < 32 ? MISTAKES_LO : MISTAKES_HI;
    return (half_mask & (1u << uint(m & 31))) != 0u;
}
vec3 center(int i) { return spheres[i].center_radius.xyz; }
float radius(int i) { return spheres[i].center_radius.w; }
float transparency(int i) { return spheres[i].emission_transparency.w; }
// The paper's test for "shade as specular": either flag, whatever the class.
bool specular_flags(Sphere s) { return s.emission_transparency.w > 0.0 || s.color_reflection.w > 0.0; }

// The paper's geometric test with Q1's early-out; false = miss. t may be NaN for a NaN
// ray, exactly as on the CPU (every comparison with NaN is false). Branch-free: the early
// outs become the returned condition (a divergent branch costs both sides on SIMD lanes).
bool intersect_paper(int i, vec3 o, vec3 d, out float t) {
    vec3 l = center(i) - o;
    float tca = dot3(l, d);
    float d2 = dot3(l, l) - tca * tca;
    float r2 = radius(i) * radius(i);
    float thc = sqrt(max(r2 - d2, 0.0));
    float t0 = tca - thc;
    // The root slips: negative_root_hit keeps a t0 behind the origin, near_root_only calls
    // the sphere missed when t0 < 0 (written as student_slips.h does, NaN included).
    bool negative_root = mistake(M_negative_root_hit), near_only = mistake(M_near_root_only);
    bool keep_t0 = (negative_root || near_only) ? (t0 >= 0.0 || negative_root) : !(t0 < 0.0);
    t = (keep_t0 && !mistake(M_far_root)) ? t0 : tca + thc;
    return !(tca < 0.0) && !(d2 > r2) && (keep_t0 || !near_only);
}

// Haines et al.'s robust quadratic, in double as in sphere.h (float32 loses the origin's
// position relative to the huge floor's centre); nearest root in (t_min, t_max).
bool intersect_robust(int i, vec3 o, vec3 d, float t_min, float t_max, out float t) {
    dvec3 oc = dvec3(o) - dvec3(center(i));
    dvec3 dd = dvec3(d);
    double b = dot3(oc, dd);
    dvec3 perpendicular = oc - dd * b;
    double r2 = double(radius(i)) * double(radius(i));
    double disc = r2 - dot3(perpendicular, perpendicular);
    t = 0.0;
    if (disc < 0.0) return false;
    double c = dot3(oc, oc) - r2;
    double q = -b - (b < 0.0 ? -sqrt(disc) : sqrt(disc));
    double t0 = q != 0.0 ? c / q : 0.0;
    double t1 = q;
    if (t0 > t1) { double s = t0; t0 = t1; t1 = s; }
    float f0 = float(t0), f1 = float(t1);
    if (mistake(M_far_root)) { t = f1; return t_min < f1 && f1 < t_max; }
    if (t_min < f0 && f0 < t_max) { t = f0; return true; }
    if (f0 <= t_min && mistake(M_negative_root_hit)) { t = f0; return true; }
    if (f0 <= t_min && mistake(M_near_root_only)) return false;
    if (t_min < f1 && f1 < t_max) { t = f1; return true; }
    return false;
}

bool nearest_hit(vec3 o, vec3 d, int skip, out int index, out float t_near) {
    index = -1;
    t_near = INF;
    bool paper = quirk(1);
    // Loops without `continue` or `break`, so that the compiler unrolls them and each
    // sphere's data is a constant rather than a per-lane load.
    for (int i = 0; i < SPHERE_COUNT; ++i) {
        float t;
        bool hit = paper ? intersect_paper(i, o, d, t) : intersect_robust(i, o, d, 0.0, t_near, t);
        if (i != skip && hit && t < t_near) { t_near = t; index = i; }
    }
    return index >= 0;
}

bool blocks(int j, vec3 o, vec3 d, float max_t) {
    float t;
    if (quirk(1)) return intersect_paper(j, o, d, t) && t < max_t;
    return intersect_robust(j, o, d, 0.0, max_t, t);
}

float offset_at(vec3 p) {
    if (mistake(M_no_offset)) return 0.0;
    if (quirk(1)) return BIAS;
    return BIAS * (1.0 + max(abs(p.x), max(abs(p.y), abs(p.z))));
}

// mix + (1 - mix) (1 - facing)^power, the product left to right (fresnel.h's paper_fresnel);
// FRESNEL_MIX and FRESNEL_POWER are the paper's 0.1 and 3 unless rtdemo --fresnel-mix/-power.
float paper_fresnel(float facing) {
    float f = 1.0 - facing;
    float rise = 1.0 - FRESNEL_MIX;
    int power = mistake(M_fresnel_exponent) ? 2 : FRESNEL_POWER;
    for (int i = 0; i < power; ++i) rise *= f;
    return FRESNEL_MIX + rise;
}

float dielectric_fresnel(float cos_theta_i, float eta) {
    if (eta == 1.0) return 0.0;
    bool outside = cos_theta_i >= 0.0;
    float eta_it = outside ? eta : 1.0 / eta;
    float eta_ti = 1.0 / eta_it;
    float cos_i = abs(cos_theta_i);
    float cos_t_sqr = 1.0 - eta_ti * eta_ti * (1.0 - cos_i * cos_i);
    if (cos_t_sqr <= 0.0) return 1.0;
    float cos_t = sqrt(cos_t_sqr);
    float a_s = (cos_i - eta_it * cos_t) / (cos_i + eta_it * cos_t);
    float a_p = (cos_t - eta_it * cos_i) / (cos_t + eta_it * cos_i);
    return clamp(0.5 * (a_s * a_s + a_p * a_p), 0.0, 1.0);
}

// Step 5 of docs/paper-model.md: direct light at p on sphere `hit`.
vec3 shade_direct(int hit, vec3 p, vec3 n) {
    vec3 origin = p + n * offset_at(p);
    vec3 aim_from = quirk(1) ? p : origin;
    float shared_shadow = 1.0;  // Q4
    vec3 c = vec3(quirk(11) ? 1.0 : 0.0);  // Q11: the paper's colour starts at 1
    Sphere shaded = sphere_at(hit);
    vec3 surface = shaded.color_reflection.rgb;
    // light_colour_from_hit reads the light's colour from the shaded sphere: nothing unless
    // that sphere is a light itself.
    bool from_hit = mistake(M_light_colour_from_hit);
    bool adds = !(from_hit && shaded.light_intensity.w == 0.0);
#if LIGHT_COUNT > 0
    for (int li = 0; li < LIGHT_COUNT; ++li) {
        int light = LIGHTS[li];
        vec3 to_light = center(light) - (mistake(M_light_dir_from_normal) ? n : aim_from);
        float dist = length(to_light);
        vec3 l = mistake(M_shadow_dir_unnormalized) ? to_light : to_light / dist;
        l = mistake(M_light_dir_reversed) ? -l : l;
        // Q12: no Lambert cosine, so a light behind the surface is tested and counts too.
        float lambert = quirk(12) ? 1.0 : max(0.0, dot3(n, l));
        float transmission = 1.0;
        if (effect(0) && !mistake(M_no_shadows) && (quirk(4) || lambert > 0.0)) {
            float max_t = (quirk(5) || mistake(M_shadow_past_light)) ? INF : dist;
            bool tested = false;  // shadow_first_only: the first sphere tested decides alone
            for (int j = 0; j < SPHERE_COUNT; ++j) {
                // Evaluated for every sphere and applied by select: no divergent branch.
                bool blocked = blocks(j, origin, l, max_t);
                bool tests = (j != light || mistake(M_light_blocks_itself)) &&
                             !(j == hit && !quirk(1)) &&
                             !(mistake(M_shadow_skips_glass) && transparency(j) > 0.0);
                bool counts = blocked && tests && !(tested && mistake(M_shadow_first_only));
                tested = tested || tests;
                float opacity = quirk(9) ? 1.0 - transparency(j) : 1.0;
                if (quirk(4)) {
                    float next = max(0.0, shared_shadow - opacity);
                    shared_shadow = counts ? next : shared_shadow;
                    transmission *= counts ? shared_shadow : 1.0;
                } else {
                    transmission *= counts ? 1.0 - opacity : 1.0;  // 0 stays 0: no early exit needed
                }
            }
        }
        if (quirk(7)) {
            vec3 emission = from_hit ? shaded.emission_transparency.rgb
                                     : spheres[light].emission_transparency.rgb;
            c += adds ? surface * emission * (transmission * lambert) : vec3(0.0);
        } else {
            vec3 from_p = center(light) - p;
            float scale = transmission * lambert / dot3(from_p, from_p);
            c += adds ? surface * spheres[light].light_intensity.rgb * (scale / PI) : vec3(0.0);
        }
    }
#endif
    return c;
}

vec3 trace(vec3 origin, vec3 dir) {
    // The current ray, and the stack of refracted rays waiting (slots written and read by
    // selects over constant indices: a per-lane index into an array costs a scatter).
    vec3 o = origin, d = dir, w = vec3(1.0);
    int depth = 0, skip = -1;
    vec3 stack_o[STACK_SIZE], stack_d[STACK_SIZE], stack_w[STACK_SIZE];
    int stack_depth[STACK_SIZE];
    for (int k = 0; k < STACK_SIZE; ++k) {
        stack_o[k] = vec3(0.0);
        stack_d[k] = vec3(0.0);
        stack_w[k] = vec3(0.0);
        stack_depth[k] = 0;
    }
    int sp = 0;
    bool walking = true;
    vec3 total = vec3(0.0);
    int depth_limit = mistake(M_depth_cut) ? MAX_DEPTH - 1 : MAX_DEPTH;  // off by one
    vec3 background = mistake(M_black_background) ? vec3(0.0) : BACKGROUND;
    while (walking) {
        int idx;
        float t;
        bool hit = nearest_hit(o, d, skip, idx, t);
        Sphere S = sphere_at(idx);
        vec3 p = o + d * t;
        vec3 n0 = p - S.center_radius.xyz;
        n0 = mistake(M_normal_not_normalized) ? n0 : unit(n0);
        // The normal's slips: the inside test turned round, the flip forgotten, the sign wrong.
        bool inside = (dot3(d, n0) > 0.0) != mistake(M_inside_test_reversed);
        vec3 n = (inside && !mistake(M_no_inside_flip)) ? -n0 : n0;
        n = mistake(M_flipped_normal) ? -n : n;

        // What this ray adds: the background, a light's radiance, or the surface's direct
        // light (Q6: specular surfaces at the depth limit get none) and Q7's emission; under
        // Q13 a sphere's own light is never added (a light is shaded like any surface).
        bool own_light = !quirk(13);
        bool light_hit = hit && own_light && !quirk(7) && S.light_intensity.w > 0.0;
        bool surface = hit && !light_hit;
        bool spec = specular_flags(S);
        bool recurse = surface && spec && depth < depth_limit;
        bool direct = surface && !recurse && !(spec && !quirk(6));
        float r = S.center_radius.w;
        total += !hit ? w * background : vec3(0.0);
        total += light_hit ? w * S.light_intensity.rgb / (PI * r * r) : vec3(0.0);
        vec3 direct_light = shade_direct(idx, p, n);
        total += direct ? w * direct_light : vec3(0.0);
        total += (surface && own_light && quirk(7)) ? w * S.emission_transparency.rgb : vec3(0.0);

        // Its children (step 4 of docs/paper-model.md).
        float d_dot_n = dot3(d, n);
        float facing = mistake(M_fresnel_facing_sign) ? d_dot_n : max(0.0, -d_dot_n);
        float offset = offset_at(p);
        float tr = S.emission_transparency.w;
        float ior = S.ior.x;
        bool refractive = tr > 0.0;
        float eta = (quirk(2) || !inside) ? 1.0 / ior : ior;
        eta = mistake(M_eta_inverted) ? 1.0 / eta : eta;
        eta = (mistake(M_eta_one_leaving) && inside) ? 1.0 : eta;
        eta = mistake(M_eta_ior_both) ? ior : eta;
        float cosi = -d_dot_n;
        float k = 1.0 - eta * eta * (1.0 - cosi * cosi);
        bool total_internal = refractive && k < 0.0 && !quirk(3);
        // With Q3 present and k < 0 this is NaN, like the original's sqrt(k).
        float cos_dir = mistake(M_cosi_sign) ? -cosi : cosi;
        vec3 t_dir = unit(d * eta + n * (eta * cos_dir - sqrt(k)));
        float fresnel = total_internal ? 1.0
                      : quirk(8) ? paper_fresnel(facing)
                      : refractive ? dielectric_fresnel(inside ? -facing : facing, ior) : 1.0;
        fresnel = (mistake(M_fresnel_constant) && !total_internal) ? 0.5 : fresnel;
        vec3 surface_colour = S.color_reflection.rgb;
        float t_weight = quirk(8) ? 1.0 : (refractive ? eta * eta : 1.0);
        // The mix's slips (student_slips.h's mix_with_slip); fresnel_missing overrides them.
        bool unmixed = mistake(M_fresnel_missing);
        bool swapped = mistake(M_fresnel_weights_swapped) && !unmixed;
        float f_reflect = unmixed ? 1.0 : swapped ? 1.0 - fresnel : fresnel;
        float f_refract = unmixed ? 1.0 : swapped ? fresnel : 1.0 - fresnel;
        float tr_weight = (mistake(M_refraction_unweighted) && !unmixed) ? 1.0 : tr;
        vec3 reflect_tint =
            (mistake(M_reflection_untinted) && !unmixed) ? vec3(1.0) : surface_colour;
        bool push = recurse && refractive && !total_internal && effect(2) && sp < STACK_SIZE;
        vec3 push_o = mistake(M_refraction_bias_outside) ? p + n * offset : p - n * offset;
        vec3 push_w = w * surface_colour * (f_refract * tr_weight * t_weight);
        for (int slot = 0; slot < STACK_SIZE; ++slot) {
            bool here = push && sp == slot;
            stack_o[slot] = here ? push_o : stack_o[slot];
            stack_d[slot] = here ? t_dir : stack_d[slot];
            stack_w[slot] = here ? push_w : stack_w[slot];
            stack_depth[slot] = here ? depth + 1 : stack_depth[slot];
        }
        sp += push ? 1 : 0;

        // The next ray: the reflected one, else the top of the stack, else the walk ends.
        bool reflect = recurse && effect(1);
        int top = sp - 1;
        vec3 pop_o = stack_o[0], pop_d = stack_d[0], pop_w = stack_w[0];
        int pop_depth = stack_depth[0];
        for (int slot = 1; slot < STACK_SIZE; ++slot) {
            bool here = top == slot;
            pop_o = here ? stack_o[slot] : pop_o;
            pop_d = here ? stack_d[slot] : pop_d;
            pop_w = here ? stack_w[slot] : pop_w;
            pop_depth = here ? stack_depth[slot] : pop_depth;
        }
        o = reflect ? p + n * offset : pop_o;
        vec3 mirrored = mistake(M_reflect_sign) ? d + n * (2.0 * d_dot_n) : d - n * (2.0 * d_dot_n);
        d = reflect ? unit(mirrored) : pop_d;
        w = reflect ? w * reflect_tint * f_reflect : pop_w;
        depth = reflect ? depth + 1 : pop_depth;
        skip = (reflect && !quirk(1) && !inside) ? idx : -1;
        walking = reflect || sp > 0;
        sp -= (!reflect && sp > 0) ? 1 : 0;
    }
    return total;
}

// The camera's slips as camera_rays.cpp has them (fov_full_angle is in half_height, set by
// gl_program.cpp).
// CAMERA_MAP (rtdemo --camera-map: SU, OU, SV, OV) replaces the field of view and aspect;
// `precise` keeps the product and sum apart, as the CPU rounds them.
vec3 camera_dir(float px, float py) {
#ifdef CAMERA_MAP
    precise float xx = (2.0 * px / size.x - 1.0) * CAMERA_MAP.x + CAMERA_MAP.y;
    precise float yy = (1.0 - 2.0 * py / size.y) * CAMERA_MAP.z + CAMERA_MAP.w;
#else
    float aspect = mistake(M_aspect_ratio_missing) ? 1.0 : size.x / size.y;
    float xx = (2.0 * px / size.x - 1.0) * half_height * aspect;
    float yy = (1.0 - 2.0 * py / size.y) * half_height;
#endif
    vec3 dir = cam_right * xx + cam_up * yy + cam_forward;
    return mistake(M_ray_dir_unnormalized) ? dir : unit(dir);
}

vec3 srgb_encode(vec3 linear) {
    vec3 v = clamp(linear, 0.0, 1.0);
    return mix(12.92 * v, 1.055 * pow(v, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), v));
}

void main() {
    // Pixel (x, y) with y down, as the CPU numbers them.
    float x = floor(gl_FragCoord.x);
    float y = size.y - 1.0 - floor(gl_FragCoord.y);

    // half_pixel_offset: rays through the pixels' (and strata's) corners.
    float centre = mistake(M_half_pixel_offset) ? 0.0 : 0.5;
    vec3 d0 = camera_dir(x + centre, y + centre);
    vec3 c;
    if (strata == 1) {
        c = trace(cam_origin, d0);
    } else {
        vec3 sum = vec3(0.0);
        float k = float(strata);
        for (int sy = 0; sy < strata; ++sy)
            for (int sx = 0; sx < strata; ++sx)
                sum += trace(cam_origin, camera_dir(x + (float(sx) + centre) / k, y + (float(sy) + centre) / k));
        c = sum / (k * k);
    }
    // double_gamma: encoded once more before it is written (cpu_renderer.cpp).
    c = mistake(M_double_gamma) ? pow(c, vec3(1.0 / 2.2)) : c;

    // The AOVs: what the centre ray hits first (id -1 on a miss), the normal facing it.
    int id;
    float t;
    bool hit = nearest_hit(cam_origin, d0, -1, id, t);
    vec3 n = unit(cam_origin + d0 * t - sphere_at(id).center_radius.xyz);
    n = dot3(d0, n) > 0.0 ? -n : n;
    out_aov = vec4(float(id), hit ? t : 0.0, 0.0, 1.0);
    out_normal = vec4(hit ? n : vec3(0.0), 1.0);
    out_color = vec4(display == 1 ? srgb_encode(c) : c, 1.0);
}
