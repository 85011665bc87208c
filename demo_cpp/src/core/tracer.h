// The paper's recursive Whitted tracer (docs/paper-model.md), each quirk a switch.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "core/camera_rays.h"
#include "core/fresnel.h"
#include "core/mistakes.h"
#include "core/quirks.h"
#include "core/ray_budget.h"
#include "core/ray_recorder.h"
#include "core/scene.h"
#include "core/sphere_lanes.h"

namespace rt {

struct TraceOptions {
    QuirkSet quirks = QuirkSet::all();
    int max_depth = 5;
    // Effect switches for per-effect ablation: an effect switched off contributes nothing.
    bool shadows = true;
    bool reflection = true;
    bool refraction = true;
    // Named mistakes (mistakes.h) on top: this tracer and the packet engine implement each
    // (the packet engine some as other settings, mistake_settings.h).
    MistakeSet mistakes;
    // The paper's Fresnel curve (Q8) with other constants (a student's, or a fitted one).
    FresnelCurve fresnel_curve;
    // Another camera (camera_rays.h); both CPU engines render it.
    std::optional<CameraMap> camera_map;
};

// The paper's Fresnel curve as a render uses it: the mistake fresnel_exponent squares instead
// of cubing.
inline FresnelCurve paper_curve(const TraceOptions& opt) {
    FresnelCurve c = opt.fresnel_curve;
    if (opt.mistakes.has(Mistake::fresnel_exponent)) c.power = 2;
    return c;
}

// Rays traced, for rays/s in the benchmark: camera rays (one per sample, plus the centre ray
// for the AOVs when spp > 1), secondary (reflection, refraction) and shadow rays (one per
// light per shaded point whose light is tested).
struct RayCounts {
    std::uint64_t camera = 0, secondary = 0, shadow = 0;
    std::uint64_t total() const { return camera + secondary + shadow; }
    RayCounts& operator+=(const RayCounts& o) {
        camera += o.camera;
        secondary += o.secondary;
        shadow += o.shadow;
        return *this;
    }
};

// What the camera ray saw at a pixel, for the EXR's AOV channels.
struct PrimaryHit {
    int id = -1;           // index into scene.spheres, -1 on a miss
    float depth = 0;       // camera-ray distance, 0 on a miss
    vec3 normal{0, 0, 0};  // facing the camera, 0 on a miss
};

class Tracer {
public:
    // Precondition: `scene` outlives the tracer.
    Tracer(const Scene& scene, TraceOptions options);

    // With `first`, also reports what this ray hits (the AOVs of a camera ray), so the
    // renderer need not trace the pixel centre a second time.
    color trace(const ray& r, int depth, PrimaryHit* first = nullptr) const;
    PrimaryHit primary(const ray& r) const;
    // Step 5 of docs/paper-model.md: direct light at p (normal n) on sphere `hit_index`.
    color shade_direct(int hit_index, const point3& p, const vec3& n) const;
    // Rays traced by this tracer so far. A tracer is not shared between threads (each
    // render thread has its own copy), so counting needs no atomics.
    const RayCounts& ray_counts() const { return counts_; }
    // Events of every ray traced from now on go to `recorder` (null: none, the default).
    void set_recorder(RayRecorder* recorder) { recorder_ = recorder; }
    // Rays traced from now on are charged to `budget` (ray_budget.h; null: no limit, the
    // default); once it is spent every ray returns black at once, unwinding the tree quickly.
    void set_budget(RayBudget* budget) { budget_.budget = budget; }
    // Whether the budget is spent (the renderer stops handing out pixels); `settle` charges
    // the rays not yet charged (at the worker's end).
    bool out_of_budget(bool settle = false) const {
        return budget_.update(counts_.total(), settle);
    }

private:
    using Hit = SphereHit;
    color trace_skipping(const ray& r, int depth, int skip, PrimaryHit* first = nullptr) const;
    // trace_skipping between the recorder's begin_ray and end_ray, when there is a recorder.
    color traced(RayKind kind, const ray& r, int depth, int skip,
                 PrimaryHit* first = nullptr) const;
    // Nearest sphere along r; `skip` (or -1) is a sphere the ray cannot hit again.
    // (A plain struct, not std::optional: storing its flag byte and reloading the whole
    // value stalled store forwarding; it was the hottest line of trace_skipping in perf.)
    Hit nearest_hit(const ray& r, int skip) const;
    // Does sphere j block the shadow ray within `max_t`?
    bool blocks(int j, const ray& shadow_ray, float max_t) const;
    color shade_specular(int hit_index, const ray& r, const point3& p, const vec3& n, bool inside,
                         int depth) const;
    // Where a secondary ray leaves the surface: the paper's fixed bias, or (Q1 fixed) an
    // offset that grows with |p| so float32 rounding at large coordinates cannot re-hit.
    float offset_at(const point3& p) const;
    // Where a refracted ray starts: bias inside the surface (or outside: refraction_bias_outside).
    point3 refraction_origin(const point3& p, const vec3& n, float offset) const;
    vec3 refracted_direction(const vec3& d, const vec3& n, float eta) const;

    const Scene& scene_;
    TraceOptions opt_;
    std::vector<int> lights_;
    std::vector<color> light_intensity_;  // physical: I = pi E d0^2 per light
    mutable RayCounts counts_;
    mutable BudgetShare budget_;
    SphereLanes lanes_;
    bool use_lanes_;
    RayRecorder* recorder_ = nullptr;  // Q1 present and at most SphereLanes::kMaxSpheres spheres
};

}  // namespace rt
