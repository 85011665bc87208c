// The classic Whitted program (docs/paper-model.md, `classic` mode) ported to double
// precision, as a maintainer who "just uses double everywhere" writes it: a small value-type
// vector, std::sqrt/std::pow/std::tan on doubles, a struct per sphere and std::optional hits,
// a truncating PPM writer. Independent code written for rtval's corpus from the model's
// description; the scene (scenes/classic.json) is hard-coded.
//
//   classic_double WIDTH HEIGHT OUT.ppm
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <optional>
#include <vector>

namespace {

struct V {
    double x = 0, y = 0, z = 0;
};
V operator+(V a, V b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
V operator-(V a, V b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
V operator*(V a, double s) { return {a.x * s, a.y * s, a.z * s}; }
V operator*(V a, V b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
double dot(V a, V b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
V normalized(V a) {
    const double len = std::sqrt(dot(a, a));
    return len > 0 ? a * (1.0 / len) : a;
}

struct Sphere {
    V centre;
    double radius;
    V colour;
    double reflection = 0, transparency = 0, ior = 1;
    V emission{};
    bool specular() const { return reflection > 0 || transparency > 0; }
    bool emits() const { return emission.x > 0; }
};

const std::vector<Sphere> kScene = {
    {{0, -10004, -20}, 10000, {0.2, 0.2, 0.2}},
    {{0, 0, -20}, 4, {1.0, 0.32, 0.36}, 1, 0.5, 1.1},
    {{5, -1, -15}, 2, {0.90, 0.76, 0.46}, 1},
    {{5, 0, -25}, 3, {0.65, 0.77, 0.97}, 1},
    {{-5.5, 0, -15}, 3, {0.90, 0.90, 0.90}, 1},
    {{0, 20, -30}, 3, {0, 0, 0}, 0, 0, 1, {3, 3, 3}},
};
constexpr V kBackground{2, 2, 2};
constexpr int kMaxDepth = 5;
constexpr double kBias = 1e-4;
constexpr double kFovY = 30;

// The classic geometric test: nothing when the centre is behind the origin.
std::optional<double> hit(const Sphere& s, V o, V d) {
    const V l = s.centre - o;
    const double tca = dot(l, d);
    if (tca < 0) return std::nullopt;
    const double d2 = dot(l, l) - tca * tca;
    const double r2 = s.radius * s.radius;
    if (d2 > r2) return std::nullopt;
    const double thc = std::sqrt(r2 - d2);
    const double t0 = tca - thc;
    return t0 < 0 ? tca + thc : t0;
}

V trace(V o, V d, int depth) {
    const Sphere* best = nullptr;
    double t_best = std::numeric_limits<double>::infinity();
    for (const Sphere& s : kScene) {
        const auto t = hit(s, o, d);
        if (t && *t < t_best) {
            t_best = *t;
            best = &s;
        }
    }
    if (!best) return kBackground;
    const Sphere& s = *best;
    const V p = o + d * t_best;
    V n = normalized(p - s.centre);
    const bool inside = dot(d, n) > 0;
    if (inside) n = n * -1.0;

    V result{};
    if (s.specular() && depth < kMaxDepth) {
        const double facing = std::max(0.0, -dot(d, n));
        const double fresnel = 0.1 + 0.9 * std::pow(1 - facing, 3);
        const V reflected = trace(p + n * kBias, normalized(d - n * (2 * dot(d, n))), depth + 1);
        V refracted{};
        if (s.transparency > 0) {
            const double eta = inside ? s.ior : 1 / s.ior;
            const double cosi = -dot(n, d);
            const double k = 1 - eta * eta * (1 - cosi * cosi);
            const V t = normalized(d * eta + n * (eta * cosi - std::sqrt(k)));
            refracted = trace(p - n * kBias, t, depth + 1);
        }
        result = (reflected * fresnel + refracted * ((1 - fresnel) * s.transparency)) * s.colour;
    } else {
        for (const Sphere& light : kScene) {
            if (!light.emits()) continue;
            const V l = normalized(light.centre - p);
            bool blocked = false;
            for (const Sphere& other : kScene)
                if (&other != &light && hit(other, p + n * kBias, l)) {
                    blocked = true;
                    break;
                }
            if (!blocked) result = result + s.colour * light.emission * std::max(0.0, dot(n, l));
        }
    }
    return result + s.emission;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 4) {
        std::fprintf(stderr, "usage: %s WIDTH HEIGHT OUT.ppm\n", argv[0]);
        return 64;
    }
    const int w = std::atoi(argv[1]), h = std::atoi(argv[2]);
    if (w < 1 || h < 1) return 64;
    const double a = std::tan(kFovY / 2 * M_PI / 180), aspect = double(w) / h;
    std::vector<unsigned char> bytes;
    bytes.reserve(size_t(w) * h * 3);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const double xx = (2 * (x + 0.5) / w - 1) * a * aspect;
            const double yy = (1 - 2 * (y + 0.5) / h) * a;
            const V c = trace({0, 0, 0}, normalized({xx, yy, -1}), 0);
            for (double v : {c.x, c.y, c.z})
                bytes.push_back(static_cast<unsigned char>(std::min(1.0, v) * 255));
        }
    std::FILE* f = std::fopen(argv[3], "wb");
    if (!f) return 1;
    std::fprintf(f, "P6\n%d %d\n255\n", w, h);
    std::fwrite(bytes.data(), 1, bytes.size(), f);
    return std::fclose(f) == 0 ? 0 : 1;
}
