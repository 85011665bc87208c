// A foreign renderer for `rtval check` tests: a plain classic Whitted tracer (the
// scratchapixel program's algorithm, docs/paper-model.md's `classic` mode) of the classic
// scene, hard-coded: it ignores any scene file. Writes a binary PPM (linear, clamped, rounded).
//
//   classic_tracer OUT.ppm WIDTH HEIGHT
//
// RTVAL_TEST_BREAK=shadows builds it with one effect broken: shadow rays are never cast.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

struct Vec {
    float x, y, z;
    Vec operator+(const Vec &o) const { return {x + o.x, y + o.y, z + o.z}; }
    Vec operator-(const Vec &o) const { return {x - o.x, y - o.y, z - o.z}; }
    Vec operator*(float s) const { return {x * s, y * s, z * s}; }
    Vec operator*(const Vec &o) const { return {x * o.x, y * o.y, z * o.z}; }
    float dot(const Vec &o) const { return x * o.x + y * o.y + z * o.z; }
    Vec unit() const {
        float n = std::sqrt(dot(*this));
        return n > 0 ? *this * (1 / n) : *this;
    }
};

struct Ball {
    Vec c;
    float r;
    Vec colour, emission;
    float reflection, transparency;
    bool hit(const Vec &o, const Vec &d, float &t) const {
        Vec l = c - o;
        float tca = l.dot(d);
        if (tca < 0) return false;
        float d2 = l.dot(l) - tca * tca;
        if (d2 > r * r) return false;
        float thc = std::sqrt(r * r - d2);
        float t0 = tca - thc;
        t = t0 < 0 ? tca + thc : t0;
        return true;
    }
};

static std::vector<Ball> balls = {
    {{0, -10004, -20}, 10000, {0.2f, 0.2f, 0.2f}, {0, 0, 0}, 0, 0},
    {{0, 0, -20}, 4, {1.0f, 0.32f, 0.36f}, {0, 0, 0}, 1, 0.5f},
    {{5, -1, -15}, 2, {0.90f, 0.76f, 0.46f}, {0, 0, 0}, 1, 0},
    {{5, 0, -25}, 3, {0.65f, 0.77f, 0.97f}, {0, 0, 0}, 1, 0},
    {{-5.5f, 0, -15}, 3, {0.90f, 0.90f, 0.90f}, {0, 0, 0}, 1, 0},
    {{0, 20, -30}, 3, {0, 0, 0}, {3, 3, 3}, 0, 0},
};
static const float kBias = 1e-4f, kIor = 1.1f;
static const int kMaxDepth = 5;
static bool shadows = true;

static Vec trace(const Vec &o, const Vec &d, int depth) {
    float near = INFINITY;
    const Ball *b = nullptr;
    for (const Ball &s : balls) {
        float t;
        if (s.hit(o, d, t) && t < near) near = t, b = &s;
    }
    if (!b) return {2, 2, 2};
    Vec p = o + d * near, n = (p - b->c).unit();
    bool inside = d.dot(n) > 0;
    if (inside) n = n * -1;
    Vec colour{0, 0, 0};
    if ((b->transparency > 0 || b->reflection > 0) && depth < kMaxDepth) {
        float facing = -d.dot(n);
        float fresnel = 0.1f + 0.9f * std::pow(1 - facing, 3.0f);
        Vec r = (d - n * 2 * d.dot(n)).unit();
        Vec refl = trace(p + n * kBias, r, depth + 1), refr{0, 0, 0};
        if (b->transparency > 0) {
            float eta = inside ? kIor : 1 / kIor, cosi = -n.dot(d);
            float k = 1 - eta * eta * (1 - cosi * cosi);
            Vec t = (d * eta + n * (eta * cosi - std::sqrt(k))).unit();
            refr = trace(p - n * kBias, t, depth + 1);
        }
        colour = (refl * fresnel + refr * ((1 - fresnel) * b->transparency)) * b->colour;
    } else {
        for (size_t i = 0; i < balls.size(); ++i) {
            if (balls[i].emission.x <= 0) continue;
            Vec l = (balls[i].c - p).unit();
            float transmission = 1;
            for (size_t j = 0; shadows && j < balls.size(); ++j) {
                float t;
                if (j != i && balls[j].hit(p + n * kBias, l, t)) {
                    transmission = 0;
                    break;
                }
            }
            colour =
                colour + b->colour * balls[i].emission * (transmission * std::max(0.f, n.dot(l)));
        }
    }
    return colour + b->emission;
}

int main(int argc, char **argv) {
    if (argc != 4) {
        std::fprintf(stderr, "usage: classic_tracer OUT.ppm WIDTH HEIGHT\n");
        return 64;
    }
    const char *broken = std::getenv("RTVAL_TEST_BREAK");
    shadows = !(broken && std::strcmp(broken, "shadows") == 0);
    int w = std::atoi(argv[2]), h = std::atoi(argv[3]);
    if (w < 1 || h < 1) return 64;
    float angle = std::tan(3.14159265358979f * 0.5f * 30 / 180), aspect = float(w) / h;
    std::vector<unsigned char> px(size_t(w) * h * 3);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            Vec d = Vec{(2 * ((x + 0.5f) / w) - 1) * angle * aspect,
                        (1 - 2 * ((y + 0.5f) / h)) * angle, -1}
                        .unit();
            Vec c = trace({0, 0, 0}, d, 0);
            float v[3] = {c.x, c.y, c.z};
            for (int k = 0; k < 3; ++k) {
                float f = std::isnan(v[k]) ? 0 : std::min(1.f, std::max(0.f, v[k]));
                px[(size_t(y) * w + x) * 3 + k] = static_cast<unsigned char>(f * 255 + 0.5f);
            }
        }
    FILE *f = std::fopen(argv[1], "wb");
    if (!f) return 1;
    std::fprintf(f, "P6\n%d %d\n255\n", w, h);
    std::fwrite(px.data(), 1, px.size(), f);
    return std::fclose(f) == 0 ? 0 : 1;
}
