// The plain data the packet engine's kernels work on: the scene as arrays, the options as
// flags, and one queue of rays per bounce. Only PODs and raw pointers cross from the driver
// (packet_engine.cpp, baseline x86-64) into the kernels (compiled once per instruction set):
// no std:: template is instantiated in a kernel translation unit, so the linker can never
// choose an AVX-512 copy of shared code for a CPU without it.
#pragma once

#include <cstdint>

#include "core/fresnel.h"
#include "core/mistakes.h"
#include "core/quirks.h"

namespace rt::packet {

// Spheres as structure of arrays; every array has `count` entries.
struct SceneArrays {
    int count = 0;
    const float *cx, *cy, *cz, *radius, *r2;  // r2 = radius * radius in float (the paper's test)
    const float *col_r, *col_g, *col_b;       // surface colour
    const float *em_r, *em_g, *em_b;          // emission
    const float *rad_r, *rad_g, *rad_b;       // radiance seen on a light (physical units)
    const float *transparency, *ior;
    const int* flags;  // kLight | kSpecular
    int light_count = 0;
    const int* lights;                // sphere index of each light, in scene order
    const float *li_r, *li_g, *li_b;  // point intensity per light (light_units.h)
    float bg_r, bg_g, bg_b;
    float bias;
};
constexpr int kLight = 1, kSpecular = 2;

// The quirks present (quirks.h names them), one boolean each.
struct QuirkFlags {
#define RT_QUIRK_FLAG(name, number) bool name;
    RT_QUIRK_LIST(RT_QUIRK_FLAG)
#undef RT_QUIRK_FLAG
};

// Quirks present, effect switches and the named mistakes that change the shading (mistakes.h;
// the others are settings, mistake_settings.h): uniform over a frame.
struct Options {
    QuirkFlags quirk;
    int max_depth;
    bool shadows, reflection, refraction;
    MistakeSet mistakes;         // those the kernels read; the others are settings
    FresnelCurve fresnel_curve;  // Q8's constants, fresnel_exponent's power included
};

// Camera rays exactly as CameraRays::render_from_camera computes them.
struct CameraArrays {
    float ox, oy, oz;
    float fx, fy, fz, rx, ry, rz, ux, uy, uz;
    float half_height, aspect, width, height;
    bool unnormalized;  // ray_dir_unnormalized: the direction through the pixel, not normalised
    // A camera map (rtdemo --camera-map): u = su (2 px / W - 1) + ou, v = sv (1 - 2 py / H) + ov
    // instead of the fov and aspect, the scalar tracer's expression and order exactly.
    bool mapped;
    float su, ou, sv, ov;
};

// One bounce's rays and, at the same index, the node each becomes in the frame's tree of rays.
// A leaf's colour is known at shading; an inner node (a specular hit below the depth limit)
// keeps its weights and children, packed in `inner`, and gets its colour in resolve(): colour =
// (reflected * f + refracted * w) * surface colour, the scalar tracer's exact expression.
// Diffuse hits and inner nodes are packed in the order of their rays (a compress per vector);
// `dmask` and `smask` keep each vector's lanes that went to either, so the packed colours come
// back by the inverse expand instead of a scatter by ray index, both in one pass (resolve).
// Capacities: counts rounded up by one vector, so kernels read and write whole vectors.
struct Level {
    int count = 0;
    float *ox, *oy, *oz, *dx, *dy, *dz;
    int* skip;            // sphere the ray cannot hit again, or -1
    float *cr, *cg, *cb;  // the node's colour
    float *dr, *dg, *db;  // diffuse hits' colours, packed (resolve() writes them to cr, cg, cb)
    int *dmask, *smask;   // per vector: lanes queued as diffuse hits, lanes that are inner nodes
    int inner = 0;        // inner nodes, packed:
    float *f, *w;         //   Fresnel weight of the reflected child, weight of the refracted one
    int* sph;             //   the sphere hit
    int *crefl, *crefr;   //   children's indices in the next level, or -1
    float *ir, *ig, *ib;  //   colour (resolve)
};

// Hits waiting for shading within one shade() call, packed by kind (diffuse, specular), so
// that each kind's code runs on full vectors.
struct HitQueue {
    int count = 0;
    float *px, *py, *pz, *nx, *ny, *nz, *dx, *dy, *dz;
    int *sph, *inside;
};

// What the camera ray saw (the AOVs), per ray of level 0; null when not wanted.
struct Aov {
    float *id, *depth, *nx, *ny, *nz;
};

// Where a finished tile's pixels go, at its first pixel (as band_sink.h BandPixels): each
// channel at its own pointer, `step` floats from one pixel to the next (3: rgb and the normal
// interleaved; 1: planes); the AOVs null when not wanted. Or, with `rgb8` set (no AOVs), the
// colour as an 8-bit output's bytes, r g b per pixel (step 3), rounded when `round`
// (to_linear8).
struct TilePixels {
    float *r, *g, *b, *id, *depth, *nx, *ny, *nz;
    int step;
    unsigned char* rgb8 = nullptr;
    bool round = false;
};

struct Counts {
    std::uint64_t camera = 0, secondary = 0, shadow = 0;
};

// One instruction set's kernels.
struct Kernels {
    const char* name;
    int lanes;
    // Level 0 for a tw x th tile at (x0, y0); pixel (x, y)'s ray through (x + off_x, y + off_y).
    void (*camera)(const CameraArrays&, int x0, int y0, int tw, int th, float off_x, float off_y,
                   Level& out);
    // Nearest hits of `cur` (rays at recursion depth `depth`) and the shading of its leaves and
    // diffuse hits; its specular hits below the depth limit are left in `specular` (the
    // queues' capacity is >= cur.count + lanes).
    void (*shade)(const SceneArrays&, const Options&, int depth, Level& cur, HitQueue& diffuse,
                  HitQueue& specular, Counts&, const Aov* aov);
    // The specular hits' weights (cur's inner nodes) and their children, into `next` (capacity
    // >= 2 * specular.count + lanes, count set by the kernel). Known only now, the count of
    // specular hits sizes `next`: only memory the bounce uses is touched.
    void (*spawn)(const SceneArrays&, const Options&, Level& cur, const HitQueue& specular,
                  Level& next);
    // Only the AOVs of `cur` (the pixel-centre rays when spp > 1).
    void (*primary)(const SceneArrays&, const Options&, const Level& cur, const Aov& aov);
    // Inner nodes of `cur` from the colours of `next`; then every node's colour in its place.
    void (*resolve)(const SceneArrays&, const Options&, Level& cur, const Level& next);
    // A finished tw x th tile into `out` (row stride `width` pixels): the colour scaled by
    // `scale`; the AOVs too when `aov` is given.
    void (*store_tile)(const float* cr, const float* cg, const float* cb, float scale,
                       const Aov* aov, int tw, int th, int width, const TilePixels& out);
};

const Kernels& kernels_scalar();
const Kernels& kernels_avx2();
const Kernels& kernels_avx512();

}  // namespace rt::packet
