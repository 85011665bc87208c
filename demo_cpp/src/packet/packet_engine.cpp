#include "packet/packet_engine.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <new>
#include <optional>
#include <stdexcept>
#include <thread>
#include <vector>

#include "core/camera_rays.h"
#include "core/cpu_features.h"
#include "core/light_units.h"
#include "core/ray_budget.h"
#include "core/student_slips.h"
#include "core/worker_threads.h"
#include "packet/packet_data.h"

namespace rt {

namespace {
packet::QuirkFlags quirk_flags(const QuirkSet& q) {
    packet::QuirkFlags f{};
#define RT_QUIRK_SET(name, number) f.name = q.has(Quirk::name);
    RT_QUIRK_LIST(RT_QUIRK_SET)
#undef RT_QUIRK_SET
    return f;
}
}  // namespace

const packet::Kernels& kernels_for(Isa isa) {
    switch (isa) {
        case Isa::avx512:
            return packet::kernels_avx512();
        case Isa::avx2:
            return packet::kernels_avx2();
        case Isa::scalar:
            break;
    }
    return packet::kernels_scalar();
}

namespace {

using packet::Kernels;
using packet::Level;

// Small tiles handed out dynamically: both threads stay busy to the end of the frame, and a
// tile's queues (a few hundred rays per bounce; inside glass a bounce can double them) stay in
// the first-level cache. 16 x 8 rather than 32 x 8: as fast traced, and a third fewer pages
// of queue memory touched in a fresh process (bench/NOTES.md).
constexpr int kTileW = 16;
constexpr int kTileH = 8;

// The scene as arrays (packet_data.h), owning its storage.
struct SceneStore {
    std::vector<float> cx, cy, cz, radius, r2, col_r, col_g, col_b, em_r, em_g, em_b, rad_r, rad_g,
        rad_b, transparency, ior, li_r, li_g, li_b;
    std::vector<int> flags, lights;
    packet::SceneArrays view;

    explicit SceneStore(const Scene& scene) {
        for (int i = 0; i < static_cast<int>(scene.spheres.size()); ++i) {
            const Sphere& s = scene.spheres[i];
            cx.push_back(s.center.x);
            cy.push_back(s.center.y);
            cz.push_back(s.center.z);
            radius.push_back(s.radius);
            r2.push_back(s.radius * s.radius);
            col_r.push_back(s.surface_color.x);
            col_g.push_back(s.surface_color.y);
            col_b.push_back(s.surface_color.z);
            em_r.push_back(s.emission.x);
            em_g.push_back(s.emission.y);
            em_b.push_back(s.emission.z);
            const color rad = s.is_light() ? sphere_radiance(scene, s) : color(0.0f);
            rad_r.push_back(rad.x);
            rad_g.push_back(rad.y);
            rad_b.push_back(rad.z);
            transparency.push_back(s.transparency);
            ior.push_back(s.ior);
            flags.push_back((s.is_light() ? packet::kLight : 0) |
                            (s.has_specular_flags() ? packet::kSpecular : 0));
            if (s.is_light()) {
                lights.push_back(i);
                const color li = point_intensity(scene, s);
                li_r.push_back(li.x);
                li_g.push_back(li.y);
                li_b.push_back(li.z);
            }
        }
        view.count = static_cast<int>(cx.size());
        // Padded to a vector of 16: a scene that fits one is read by permutes (packet/simd.h).
        const std::size_t padded = std::max<std::size_t>(cx.size(), 16);
        for (auto* v : {&cx, &cy, &cz, &radius, &r2, &col_r, &col_g, &col_b, &em_r, &em_g, &em_b,
                        &rad_r, &rad_g, &rad_b, &transparency, &ior})
            v->resize(padded, 0.0f);
        flags.resize(padded, 0);
        view.cx = cx.data(), view.cy = cy.data(), view.cz = cz.data();
        view.radius = radius.data(), view.r2 = r2.data();
        view.col_r = col_r.data(), view.col_g = col_g.data(), view.col_b = col_b.data();
        view.em_r = em_r.data(), view.em_g = em_g.data(), view.em_b = em_b.data();
        view.rad_r = rad_r.data(), view.rad_g = rad_g.data(), view.rad_b = rad_b.data();
        view.transparency = transparency.data(), view.ior = ior.data();
        view.flags = flags.data();
        view.light_count = static_cast<int>(lights.size());
        view.lights = lights.data();
        view.li_r = li_r.data(), view.li_g = li_g.data(), view.li_b = li_b.data();
        view.bg_r = scene.background.x, view.bg_g = scene.background.y,
        view.bg_b = scene.background.z;
        view.bias = scene.bias;
    }
};

// `arrays` arrays of `cap` entries each in one block, allocated uninitialised and grown without
// keeping their contents: every queue is refilled from scratch at each bounce, and only the
// pages a bounce writes are ever touched. (Zero-filled vectors of the worst case's size touched
// all of it: about 400 page faults per thread and frame, bench/NOTES.md.)
template <class T>
class Block {
public:
    // Room for n entries per array; returns whether the arrays moved (their contents are lost).
    bool reserve(std::size_t n, int arrays) {
        if (n <= cap_) return false;
        const std::size_t cap = (n * 3 / 2 + 15) / 16 * 16;  // arrays start 64 bytes apart
        data_.reset(new (std::align_val_t{64}) T[cap * static_cast<std::size_t>(arrays)]);
        cap_ = cap;
        return true;
    }
    T* array(int k) { return data_.get() + cap_ * static_cast<std::size_t>(k); }

private:
    struct Free {
        void operator()(T* p) const { ::operator delete[](p, std::align_val_t{64}); }
    };
    std::unique_ptr<T[], Free> data_;
    std::size_t cap_ = 0;
};

// A queue's arrays (the members of View listed in `floats` and `ints`) in two blocks, owning
// their storage; grows between bounces, never inside a kernel.
template <class View>
struct ArrayStore {
    Block<float> f;
    Block<int> i;
    View view;

    template <std::size_t F, std::size_t I>
    void reserve(int n, float* View::*const (&floats)[F], int* View::*const (&ints)[I]) {
        const std::size_t want = static_cast<std::size_t>(n);
        if (!(f.reserve(want, static_cast<int>(F)) | i.reserve(want, static_cast<int>(I)))) return;
        for (std::size_t k = 0; k < F; ++k) view.*floats[k] = f.array(static_cast<int>(k));
        for (std::size_t k = 0; k < I; ++k) view.*ints[k] = i.array(static_cast<int>(k));
    }
};

// One bounce's rays and nodes (the masks: one entry per vector).
struct LevelStore : ArrayStore<Level> {
    void reserve(int n) {
        static constexpr float* Level::*kFloats[] = {
            &Level::ox, &Level::oy, &Level::oz, &Level::dx, &Level::dy, &Level::dz,
            &Level::cr, &Level::cg, &Level::cb, &Level::f,  &Level::w,  &Level::ir,
            &Level::ig, &Level::ib, &Level::dr, &Level::dg, &Level::db};
        static constexpr int* Level::*kInts[] = {&Level::skip,  &Level::sph,   &Level::crefl,
                                                 &Level::crefr, &Level::dmask, &Level::smask};
        ArrayStore::reserve(n, kFloats, kInts);
    }
};

// One shade() call's hits of one kind.
struct QueueStore : ArrayStore<packet::HitQueue> {
    void reserve(int n) {
        using Q = packet::HitQueue;
        static constexpr float* Q::*kFloats[] = {&Q::px, &Q::py, &Q::pz, &Q::nx, &Q::ny,
                                                 &Q::nz, &Q::dx, &Q::dy, &Q::dz};
        static constexpr int* Q::*kInts[] = {&Q::sph, &Q::inside};
        ArrayStore::reserve(n, kFloats, kInts);
    }
};

// Each worker on its own cache lines: counts written per bounce must not share a line with
// the other thread's data (false sharing cost 70 % on two threads in the scalar renderer).
struct alignas(64) Worker {
    std::vector<LevelStore> levels;
    QueueStore diffuse, specular;
    std::vector<float> aov[5];  // id depth nx ny nz, per tile pixel
    std::vector<float> sum[3];
    packet::Counts counts;
    BudgetShare budget;  // the frame's ray budget, charged from `counts`
};

std::uint64_t total(const packet::Counts& c) { return c.camera + c.secondary + c.shadow; }

// Whether the worker must stop: its rays charged to the frame's budget (ray_budget.h) once
// they make a grain, checked after each bounce of a tile (a pixel's tree can explode).
bool out_of_budget(Worker& wk) { return wk.budget.update(total(wk.counts)); }

// The frame's planes, zero-filled by the kernel (image.h); the AOVs only when asked for.
RenderedImage allocate_image(int width, int height, bool aovs) {
    RenderedImage image;
    image.width = width;
    image.height = height;
    const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
    image.rgb = Plane(3 * n);
    if (!aovs) return image;
    image.id = Plane(n, -1.0f);
    image.depth = Plane(n);
    image.normal = Plane(3 * n);
    return image;
}

packet::CameraArrays camera_arrays(const Scene& scene, int width, int height, CameraSlips slips) {
    // The same basis and slips as CameraRays (camera_rays.cpp) computes.
    const Camera& cam = scene.camera;
    const vec3 forward = normalize(cam.look_at - cam.position);
    const vec3 right = normalize(cross(forward, cam.up));
    const vec3 up = cross(right, forward);
    packet::CameraArrays c{};
    c.ox = cam.position.x, c.oy = cam.position.y, c.oz = cam.position.z;
    c.fx = forward.x, c.fy = forward.y, c.fz = forward.z;
    c.rx = right.x, c.ry = right.y, c.rz = right.z;
    c.ux = up.x, c.uy = up.y, c.uz = up.z;
    c.half_height =
        std::tan(cam.fov_y * (slips.full_angle_fov ? 1.0f : 0.5f) * 3.14159265358979f / 180.0f);
    c.aspect = slips.no_aspect ? 1.0f : static_cast<float>(width) / static_cast<float>(height);
    c.unnormalized = slips.unnormalized;
    c.width = static_cast<float>(width);
    c.height = static_cast<float>(height);
    c.mapped = slips.map.has_value();
    if (c.mapped)
        c.su = slips.map->su, c.ou = slips.map->ou, c.sv = slips.map->sv, c.ov = slips.map->ov;
    return c;
}

}  // namespace

const char* isa_name(Isa isa) {
    switch (isa) {
        case Isa::scalar:
            return "scalar";
        case Isa::avx2:
            return "avx2";
        case Isa::avx512:
            return "avx512";
    }
    return "?";
}

bool supported(Isa isa) {
    switch (isa) {
        case Isa::avx512:
            return cpu_runs_avx512f();
        case Isa::avx2:
            return cpu_runs_avx2();
        case Isa::scalar:
            return true;
    }
    return false;
}

Isa best_isa() {
    if (supported(Isa::avx512)) return Isa::avx512;
    if (supported(Isa::avx2)) return Isa::avx2;
    return Isa::scalar;
}

Isa isa_from_environment() {
    const char* value = std::getenv("RTDEMO_ISA");
    if (!value || !*value) return best_isa();
    const std::string v = value;
    Isa isa;
    if (v == "scalar")
        isa = Isa::scalar;
    else if (v == "avx2")
        isa = Isa::avx2;
    else if (v == "avx512")
        isa = Isa::avx512;
    else
        throw std::invalid_argument("RTDEMO_ISA: expected scalar, avx2 or avx512, got '" + v + "'");
    if (!supported(isa)) throw std::invalid_argument("RTDEMO_ISA: this CPU does not support " + v);
    return isa;
}

namespace {

using packet::TilePixels;

// An 8-bit output's pixels from `rgb8` on: r g b per pixel.
TilePixels rgb8_pixels(unsigned char* rgb8, bool round) {
    TilePixels bytes{};
    bytes.step = 3;
    bytes.rgb8 = rgb8;
    bytes.round = round;
    return bytes;
}

// The pixel `offset` pixels on from p's first (x, or y * width + x further rows down).
TilePixels at_pixel(const TilePixels& p, std::ptrdiff_t offset) {
    if (p.rgb8) return rgb8_pixels(p.rgb8 + 3 * offset, p.round);
    const std::ptrdiff_t c = static_cast<std::ptrdiff_t>(p.step) * offset;
    if (!p.id)
        return {p.r + c, p.g + c, p.b + c, nullptr, nullptr, nullptr, nullptr, nullptr, p.step};
    return {p.r + c,  p.g + c,  p.b + c,  p.id + offset, p.depth + offset,
            p.nx + c, p.ny + c, p.nz + c, p.step};
}

packet::Options options_for(const TraceOptions& trace) {
    packet::Options opt{};
    static_assert(sizeof(packet::QuirkFlags) == kQuirkCount, "one flag per quirk");
    opt.quirk = quirk_flags(trace.quirks);
    opt.max_depth = trace.max_depth;
    opt.shadows = trace.shadows;
    opt.reflection = trace.reflection;
    opt.refraction = trace.refraction;
    opt.mistakes = trace.mistakes;
    opt.fresnel_curve = paper_curve(trace);
    return opt;
}

// What every tile of one frame shares, read-only while the workers run.
struct FrameJob {
    const Kernels& kern;
    const packet::SceneArrays& s;
    packet::Options opt;
    packet::CameraArrays cam;
    int width, height;
    int k;  // strata per axis
    float inv_samples;
    int tiles_x, tiles;
    bool aovs;
    float centre;       // of a pixel's stratum: 0.5, or 0 with --mistake half_pixel_offset
    bool double_gamma;  // --mistake double_gamma: x^(1/2.2) of the pixel's colour
    long tree_cap;      // RenderSettings::packet_tree_cap
};

// The worker's queues and buffers, sized for one tile of the frame.
void prepare(Worker& wk, const FrameJob& job) {
    const int tile_cap = kTileW * kTileH + job.kern.lanes;
    wk.levels.resize(static_cast<std::size_t>(job.opt.max_depth) + 2);
    wk.levels[0].reserve(tile_cap);
    for (auto& v : wk.aov) v.assign(static_cast<std::size_t>(tile_cap), 0.0f);
    for (auto& v : wk.sum) v.assign(static_cast<std::size_t>(tile_cap), 0.0f);
}

// One sample per pixel of the region through all bounces; the colours end in level 0. Gives up
// (false) once the tree passes the frame's tree_cap rays, when the region may be split.
bool trace_region(Worker& wk, const FrameJob& job, const packet::Aov* with_aov, bool may_give_up) {
    const Kernels& kern = job.kern;
    const int lanes = kern.lanes;
    int last = 0;
    long tree = wk.levels[0].view.count;
    for (int d = 0;; ++d) {
        LevelStore& next = wk.levels[static_cast<std::size_t>(d) + 1];
        const int n = wk.levels[d].view.count;
        wk.diffuse.reserve(n + lanes);
        wk.specular.reserve(n + lanes);
        kern.shade(job.s, job.opt, d, wk.levels[d].view, wk.diffuse.view, wk.specular.view,
                   wk.counts, d == 0 ? with_aov : nullptr);
        next.reserve(2 * wk.specular.view.count + lanes);
        kern.spawn(job.s, job.opt, wk.levels[d].view, wk.specular.view, next.view);
        last = d;
        tree += next.view.count;
        if (may_give_up && tree > job.tree_cap) return false;
        if (out_of_budget(wk)) return false;
        if (next.view.count == 0) break;
    }
    for (int d = last; d >= 0; --d)
        kern.resolve(job.s, job.opt, wk.levels[d].view, wk.levels[d + 1].view);
    return true;
}

// A rectangle of pixels within a tile.
struct Region {
    int x0, y0, w, h;
};

// The region traced and stored into `out`, its first pixel; false (nothing stored) where
// trace_region gave up.
bool render_region(Worker& wk, const FrameJob& job, const Region& r, const packet::Aov& aov,
                   const TilePixels& out) {
    const Kernels& kern = job.kern;
    const float centre = job.centre;
    const int k = job.k;
    const int n = r.w * r.h;
    const bool may_give_up = n > 1;
    Level& l0 = wk.levels[0].view;
    const float* cr = l0.cr;
    const float* cg = l0.cg;
    const float* cb = l0.cb;
    kern.camera(job.cam, r.x0, r.y0, r.w, r.h, centre, centre, l0);
    if (k == 1) {
        if (!trace_region(wk, job, job.aovs ? &aov : nullptr, may_give_up)) return false;
    } else {
        kern.primary(job.s, job.opt, l0, aov);
        wk.counts.camera += static_cast<std::uint64_t>(n);
        for (auto& v : wk.sum) std::fill(v.begin(), v.begin() + n, 0.0f);
        for (int sy = 0; sy < k; ++sy)
            for (int sx = 0; sx < k; ++sx) {
                const float off_x = (sx + centre) / k, off_y = (sy + centre) / k;
                kern.camera(job.cam, r.x0, r.y0, r.w, r.h, off_x, off_y, l0);
                if (!trace_region(wk, job, nullptr, may_give_up)) return false;
                for (int i = 0; i < n; ++i) {
                    wk.sum[0][i] += l0.cr[i];
                    wk.sum[1][i] += l0.cg[i];
                    wk.sum[2][i] += l0.cb[i];
                }
            }
        cr = wk.sum[0].data(), cg = wk.sum[1].data(), cb = wk.sum[2].data();
    }
    float inv_samples = job.inv_samples;
    if (job.double_gamma) {
        // As the scalar renderer: the mean first, then the power, then stored unscaled.
        const float* in[] = {cr, cg, cb};
        for (int c = 0; c < 3; ++c)
            for (int i = 0; i < n; ++i) wk.sum[c][i] = std::pow(in[c][i] * inv_samples, 1 / 2.2f);
        cr = wk.sum[0].data(), cg = wk.sum[1].data(), cb = wk.sum[2].data();
        inv_samples = 1.0f;
    }
    kern.store_tile(cr, cg, cb, inv_samples, job.aovs ? &aov : nullptr, r.w, r.h, job.width, out);
    return true;
}

// Tile number `tile` traced and stored into `out`, its band's pixels: whole, or pixel by
// pixel where its tree of rays grows past tree_cap (the rays counted once either way). A tree
// of acne in glass can pass 10^7 rays a tile (about 100 bytes each), and most of its time
// went to the kernel handing out fresh pages (bench/NOTES.md); each pixel's rays are its own,
// so the image is the same.
void render_tile(Worker& wk, const FrameJob& job, int tile, const packet::Aov& aov,
                 const TilePixels& out) {
    const int x0 = (tile % job.tiles_x) * kTileW, y0 = tile / job.tiles_x * kTileH;
    const Region whole{x0, y0, std::min(kTileW, job.width - x0), std::min(kTileH, job.height - y0)};
    const packet::Counts before = wk.counts;
    if (render_region(wk, job, whole, aov, at_pixel(out, x0)) || wk.budget.stopped) return;
    wk.counts = before;
    if (wk.budget.charged > total(before)) {  // the rays are traced and charged again
        wk.budget.budget->refund(wk.budget.charged - total(before));
        wk.budget.charged = total(before);
    }
    for (int y = 0; y < whole.h; ++y)
        for (int x = 0; x < whole.w && !wk.budget.stopped; ++x) {
            const std::ptrdiff_t at = static_cast<std::ptrdiff_t>(y) * job.width + x0 + x;
            render_region(wk, job, {x0 + x, y0 + y, 1, 1}, aov, at_pixel(out, at));
        }
}

// The frame's tiles handed out dynamically, band after band (a band: kTileH full rows). Before
// each tile of band b, `target(b)` says where the band's rows go (TilePixels of its first
// pixel: the frame's planes at its rows, or a buffer then handed to a BandSink; row stride: the
// frame's width); the thread that finishes a band's last tile calls `band_done(b)` (the other
// threads' stores to it are visible then).
template <class Target, class Done>
void render_tiles(const Scene& scene, const RenderSettings& settings, Isa isa, RayCounts* rays,
                  Target target, Done band_done) {
    const SceneStore store(scene);
    const int width = settings.width, height = settings.height;
    const int k = strata_per_axis(settings.spp);
    const int tiles_x = (width + kTileW - 1) / kTileW;
    const int bands = (height + kTileH - 1) / kTileH;
    const FrameJob job{kernels_for(isa),
                       store.view,
                       options_for(settings.trace),
                       camera_arrays(scene, width, height, camera_slips(settings.trace)),
                       width,
                       height,
                       k,
                       1.0f / static_cast<float>(k * k),
                       tiles_x,
                       tiles_x * bands,
                       settings.aovs,
                       settings.trace.mistakes.has(Mistake::half_pixel_offset) ? 0.0f : 0.5f,
                       settings.trace.mistakes.has(Mistake::double_gamma),
                       settings.packet_tree_cap};
    std::optional<RayBudget> budget;
    if (settings.ray_budget > 0) budget.emplace(settings.ray_budget);
    std::unique_ptr<std::atomic<int>[]> tiles_left(new std::atomic<int>[bands]);
    for (int b = 0; b < bands; ++b) tiles_left[b] = tiles_x;

    alignas(64) std::atomic<int> next_tile{0};
    std::vector<Worker> workers(static_cast<std::size_t>(settings.threads));
    auto work = [&](Worker& wk) {
        prepare(wk, job);
        wk.budget.budget = budget ? &*budget : nullptr;
        const packet::Aov aov{wk.aov[0].data(), wk.aov[1].data(), wk.aov[2].data(),
                              wk.aov[3].data(), wk.aov[4].data()};
        for (int tile = next_tile++; tile < job.tiles; tile = next_tile++) {
            const int band = tile / tiles_x;
            // Once the budget is spent the tiles are still handed out and their bands handed
            // over (untraced, thrown away with the output): no thread waits on a band slot
            // (BandSlots) that a stopped thread would never free.
            if (!wk.budget.stopped) render_tile(wk, job, tile, aov, target(band));
            if (tiles_left[band].fetch_sub(1) == 1) band_done(band);
        }
        wk.budget.update(total(wk.counts), true);
    };
    run_workers(static_cast<int>(workers.size()),
                [&](int i) { work(workers[static_cast<std::size_t>(i)]); });
    if (budget) budget->check();
    if (rays) {
        *rays = {};
        for (const Worker& w : workers)
            *rays += RayCounts{w.counts.camera, w.counts.secondary, w.counts.shadow};
    }
}

}  // namespace

RenderedImage render_packet(const Scene& scene, const RenderSettings& settings, Isa isa,
                            RayCounts* rays) {
    RenderedImage image = allocate_image(settings.width, settings.height, settings.aovs);
    render_packet(scene, settings, isa, image, rays);
    return image;
}

void render_packet(const Scene& scene, const RenderSettings& settings, Isa isa,
                   RenderedImage& image, RayCounts* rays) {
    const std::size_t width = static_cast<std::size_t>(settings.width);
    const bool aovs = settings.aovs;
    auto rows_of_image = [&](int band) {
        const std::size_t first = static_cast<std::size_t>(band) * kTileH * width;
        float* rgb = image.rgb.data() + 3 * first;
        if (!aovs)
            return TilePixels{rgb,     rgb + 1, rgb + 2, nullptr, nullptr,
                              nullptr, nullptr, nullptr, 3};
        float* n = image.normal.data() + 3 * first;
        return TilePixels{
            rgb,   rgb + 1, rgb + 2, image.id.data() + first, image.depth.data() + first, n,
            n + 1, n + 2,   3};
    };
    render_tiles(scene, settings, isa, rays, rows_of_image, [](int) {});
}

namespace {

// Band buffers for a BandSink: the first tile of a band takes the lowest free slot, and the
// hand-over frees it. Tiles are handed out in order, so every band holding a slot has a thread
// in it (tracing one of its tiles, or handing it over): at most one slot per thread is in use,
// the lowest ones, and only their pages are ever touched. When the host stops a thread midway
// through a tile, the others go on with the bands after it instead of waiting for that band's
// slot (with band b in slot b mod 6, a stopped thread held up the frame for up to 5 ms,
// bench/NOTES.md). A thread waits for a slot only with more threads than slots, and never while
// a tile of its own is unfinished, so the bands holding slots always finish.
// The layout is the sink's (BandSink::step): rgb and normal interleaved, or planes; or the
// colour as the sink's bytes (BandSink::rgb8, a frame without AOVs).
class BandSlots {
public:
    // `rgb8`: none for floats.
    BandSlots(int bands, std::size_t band_pixels, bool aovs, int step,
              std::optional<PpmRounding> rgb8)
        : count_(slots_for(bands, (aovs ? 8 : 3) * band_pixels)),
          pixels_(band_pixels),
          floats_((aovs ? 8 : 3) * band_pixels),
          aovs_(aovs),
          step_(step),
          rgb8_(rgb8),
          slot_of_(new std::atomic<int>[static_cast<std::size_t>(bands)]),
          free_(count_ == 64 ? ~0ull : (1ull << count_) - 1),
          // Uninitialised and untouched until used: every pixel of a band is stored by its
          // tiles before it is handed over.
          planes_(new float[floats_ * static_cast<std::size_t>(count_)]) {
        for (int i = 0; i < bands; ++i) slot_of_[i] = kNone;
    }
    // Band b's buffers (its slot taken by the first tile that asks).
    TilePixels acquire(int b) {
        int slot = slot_of_[b].load(std::memory_order_acquire);
        if (slot < 0) slot = assign(b);
        float* p = planes_.get() + floats_ * static_cast<std::size_t>(slot);
        if (rgb8_)  // 3 bytes a pixel in the slot's first quarter
            return rgb8_pixels(reinterpret_cast<unsigned char*>(p), *rgb8_ == PpmRounding::round);
        // Interleaved: r g b run together, as do n.x n.y n.z; planes: one after the other.
        const std::size_t next = step_ == 1 ? pixels_ : 1;
        float* n = p + 5 * pixels_;
        if (!aovs_)
            return {p, p + next, p + 2 * next, nullptr, nullptr, nullptr, nullptr, nullptr, step_};
        return {p,        p + next,     p + 2 * next, p + 3 * pixels_, p + 4 * pixels_, n,
                n + next, n + 2 * next, step_};
    }
    // Band b handed over: its slot is free again.
    void release(int b) {
        free_.fetch_or(1ull << slot_of_[b].load(std::memory_order_relaxed),
                       std::memory_order_release);
    }

private:
    static constexpr int kNone = -1, kAssigning = -2;

    // At most 64 slots (one bit each) and 64 MB of them, at least 4 (any 1 would do).
    static int slots_for(int bands, std::size_t floats) {
        const std::size_t by_memory = (std::size_t{64} << 20) / (4 * floats);
        return std::max(
            1, std::min({bands, 64,
                         std::max(4, static_cast<int>(std::min<std::size_t>(by_memory, 64)))}));
    }

    int assign(int b) {
        int expected = kNone;
        if (slot_of_[b].compare_exchange_strong(expected, kAssigning, std::memory_order_acq_rel)) {
            const int slot = take_free();
            slot_of_[b].store(slot, std::memory_order_release);
            return slot;
        }
        int slot;  // another tile of the band is taking its slot
        for (int spins = 0; (slot = slot_of_[b].load(std::memory_order_acquire)) < 0; ++spins)
            if (spins > 64) std::this_thread::yield();
        return slot;
    }
    int take_free() {
        for (int spins = 0;; ++spins) {
            std::uint64_t f = free_.load(std::memory_order_acquire);
            while (f != 0) {
                const int slot = __builtin_ctzll(f);
                if (free_.compare_exchange_weak(f, f & ~(1ull << slot), std::memory_order_acq_rel))
                    return slot;
            }
            if (spins > 64) std::this_thread::yield();
        }
    }

    int count_;
    std::size_t pixels_, floats_;
    bool aovs_;
    int step_;
    std::optional<PpmRounding> rgb8_;
    std::unique_ptr<std::atomic<int>[]> slot_of_;  // per band: its slot, kNone or kAssigning
    std::atomic<std::uint64_t> free_;              // bit s: slot s is free
    std::unique_ptr<float[]> planes_;  // per slot: r g b, then id, depth, n.x n.y n.z with AOVs
};

}  // namespace

void render_packet(const Scene& scene, const RenderSettings& settings, Isa isa, BandSink& sink,
                   RayCounts* rays) {
    const int width = settings.width, height = settings.height;
    BandSlots slots((height + kTileH - 1) / kTileH, static_cast<std::size_t>(width) * kTileH,
                    settings.aovs, sink.step() == 1 ? 1 : 3,
                    settings.aovs ? std::nullopt : sink.rgb8());
    auto slot_of = [&](int band) { return slots.acquire(band); };
    auto hand_over = [&](int band) {
        const TilePixels b = slots.acquire(band);  // its own slot, taken
        const int y0 = band * kTileH;
        sink.band(y0, std::min(kTileH, height - y0), width,
                  BandPixels{b.r, b.g, b.b, b.id, b.depth, b.nx, b.ny, b.nz, b.step, b.rgb8});
        slots.release(band);
    };
    render_tiles(scene, settings, isa, rays, slot_of, hand_over);
}

}  // namespace rt
