// The speed baseline of issue 10: the paper's program as the seed structures it — a plain,
// single-threaded, scalar, per-pixel recursive trace over a vector of spheres, writing a PPM.
// Written here from docs/paper-model.md (paper mode), not copied. It reads the same scene files.
// Usage: seed_tracer SCENE.json OUT.ppm [classic]  (classic: the scratchapixel rules, Q2 Q4 Q9)
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

namespace {

struct V {
    float x, y, z;
    V operator+(const V& o) const { return {x + o.x, y + o.y, z + o.z}; }
    V operator-(const V& o) const { return {x - o.x, y - o.y, z - o.z}; }
    V operator*(float s) const { return {x * s, y * s, z * s}; }
    V operator*(const V& o) const { return {x * o.x, y * o.y, z * o.z}; }
    float dot(const V& o) const { return x * o.x + y * o.y + z * o.z; }
    V norm() const {
        float l = std::sqrt(dot(*this));
        return {x / l, y / l, z / l};
    }
};

struct Orb {
    V center, color, emission;
    float radius2, reflection, transparency, ior;
    bool hit(const V& o, const V& d, float& t0, float& t1) const {
        V l = center - o;
        float tca = l.dot(d);
        if (tca < 0) return false;
        float d2 = l.dot(l) - tca * tca;
        if (d2 > radius2) return false;
        float thc = std::sqrt(radius2 - d2);
        t0 = tca - thc;
        t1 = tca + thc;
        return true;
    }
};

std::vector<Orb> orbs;
bool classic = false;
V background;
int max_depth;
float bias;

V trace(const V& o, const V& d, int depth) {
    float tnear = std::numeric_limits<float>::infinity();
    const Orb* orb = nullptr;
    for (const Orb& s : orbs) {
        float t0, t1;
        if (s.hit(o, d, t0, t1)) {
            if (t0 < 0) t0 = t1;
            if (t0 < tnear) {
                tnear = t0;
                orb = &s;
            }
        }
    }
    if (!orb) return background;
    V p = o + d * tnear, n = (p - orb->center).norm(), c{0, 0, 0};
    bool inside = d.dot(n) > 0;
    if (inside) n = n * -1;
    if ((orb->transparency > 0 || orb->reflection > 0) && depth < max_depth) {
        float facing = std::max(0.0f, -d.dot(n));
        float f = 0.1f + 0.9f * std::pow(1 - facing, 3.0f);
        V r = (d - n * 2 * d.dot(n)).norm();
        V refl = trace(p + n * bias, r, depth + 1), refr{0, 0, 0};
        if (orb->transparency > 0) {
            float eta = (classic && inside) ? orb->ior : 1 / orb->ior, cosi = -n.dot(d),
                  k = 1 - eta * eta * (1 - cosi * cosi);
            V t = (d * eta + n * (eta * cosi - std::sqrt(k))).norm();
            refr = trace(p - n * bias, t, depth + 1);
        }
        c = (refl * f + refr * ((1 - f) * orb->transparency)) * orb->color;
    } else {
        float shadow = 1;
        for (size_t i = 0; i < orbs.size(); ++i) {
            const Orb& light = orbs[i];
            if (!(light.emission.x > 0 || light.emission.y > 0 || light.emission.z > 0)) continue;
            float transmission = 1;
            V l = (light.center - p).norm();
            for (size_t j = 0; j < orbs.size(); ++j) {
                float t0, t1;
                if (i != j && orbs[j].hit(p + n * bias, l, t0, t1)) {
                    if (classic) {
                        transmission = 0;
                    } else {
                        shadow = std::max(0.0f, shadow - (1 - orbs[j].transparency));
                        transmission *= shadow;
                    }
                }
            }
            c = c + orb->color * light.emission * (transmission * std::max(0.0f, n.dot(l)));
        }
    }
    return c + orb->emission;
}

V vec(const nlohmann::json& j, V fallback) { return j.is_null() ? fallback : V{j[0], j[1], j[2]}; }

}  // namespace

int main(int argc, char** argv) {
    if (argc < 3 || argc > 4) {
        std::fprintf(stderr, "usage: seed_tracer SCENE.json OUT.ppm [classic]\n");
        return 2;
    }
    classic = argc == 4 && std::string(argv[3]) == "classic";
    std::ifstream in(argv[1]);
    nlohmann::json s = nlohmann::json::parse(in);
    const auto& cam = s.value("camera", nlohmann::json::object());
    V eye = vec(cam.value("position", nlohmann::json()), {0, 0, 0});
    V at = vec(cam.value("look_at", nlohmann::json()), {0, 0, -1});
    V up = vec(cam.value("up", nlohmann::json()), {0, 1, 0});
    float fov = cam.value("fov_y", 30.0f);
    int w = cam.value("width", 640), h = cam.value("height", 480);
    background = vec(s.value("background", nlohmann::json()), {2, 2, 2});
    max_depth = s.value("max_depth", 5);
    bias = s.value("bias", 1e-4f);
    for (const auto& o : s["spheres"])
        orbs.push_back({vec(o["center"], {}), vec(o["color"], {}),
                        vec(o.value("emission", nlohmann::json()), {0, 0, 0}),
                        o["radius"].get<float>() * o["radius"].get<float>(),
                        o.value("reflection", 0.0f), o.value("transparency", 0.0f),
                        o.value("ior", 1.1f)});
    V fw = (at - eye).norm();
    V rt{fw.y * up.z - fw.z * up.y, fw.z * up.x - fw.x * up.z, fw.x * up.y - fw.y * up.x};
    rt = rt.norm();
    V u{rt.y * fw.z - rt.z * fw.y, rt.z * fw.x - rt.x * fw.z, rt.x * fw.y - rt.y * fw.x};
    float a = std::tan(fov * 0.5f * 3.14159265f / 180.0f), aspect = float(w) / float(h);
    std::vector<V> image(static_cast<size_t>(w) * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            float xx = (2 * (x + 0.5f) / w - 1) * a * aspect, yy = (1 - 2 * (y + 0.5f) / h) * a;
            image[static_cast<size_t>(y) * w + x] = trace(eye, (rt * xx + u * yy + fw).norm(), 0);
        }
    std::ofstream out(argv[2], std::ios::binary);
    out << "P6\n" << w << " " << h << "\n255\n";
    for (const V& c : image) {
        auto byte = [](float v) {
            return static_cast<char>(std::lround(std::min(1.0f, std::max(0.0f, v)) * 255));
        };
        out << byte(c.x) << byte(c.y) << byte(c.z);
    }
    return 0;
}
