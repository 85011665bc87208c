// The classic Whitted program (docs/paper-model.md, `classic` mode) written the way the
// scratchapixel "introduction to ray tracing" lesson and its many student copies write it:
// a `Vec3<T>` template used as Vec3<float>, `#include <math.h>` with unqualified
// `sqrt`/`pow`/`tan` (so `1 / sqrt(n2)`, `eta * cosi - sqrt(k)` and `pow(1 - facing, 3)` are
// evaluated in double and stored back into floats), products evaluated left to right, and a
// truncating PPM writer `(unsigned char)(std::min(1.f, x) * 255)`. Independent code, written
// for rtval's corpus from the model's description; the scene (scenes/classic.json) is
// hard-coded.
//
//   scratch_float WIDTH HEIGHT OUT.ppm
//
// Mistake variants, one compile-time define each (see tests/corpus/programs.py):
//   -DMAX_RAY_DEPTH=N        recursion limit (the scene asks for 5)
//   -DGLASS_IOR=X            the glass's index (the scene asks for 1.1)
//   -DETA_INVERTED           ior entering glass and 1/ior leaving it
//   -DFRESNEL_SQUARE         0.1 + 0.9 (1 - facing)^2 instead of the cube
//   -DBLACK_BACKGROUND       a miss returns black
//   -DNO_INSIDE_FLIP         the normal is not turned round inside a sphere
//   -DNO_BIAS                secondary and shadow rays start on the surface
//   -DPIXEL_CORNERS          camera rays through (x, y) instead of (x + 0.5, y + 0.5)
//   -DUNTINTED_GLASS         the glass's result is never multiplied by its colour
#include <math.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <vector>

#ifndef MAX_RAY_DEPTH
#define MAX_RAY_DEPTH 5
#endif
#ifndef GLASS_IOR
#define GLASS_IOR 1.1
#endif

template <typename T>
class Vec3 {
public:
    T x, y, z;
    Vec3() : x(T(0)), y(T(0)), z(T(0)) {}
    Vec3(T v) : x(v), y(v), z(v) {}
    Vec3(T xx, T yy, T zz) : x(xx), y(yy), z(zz) {}
    T length2() const { return x * x + y * y + z * z; }
    Vec3 &normalize() {
        T n2 = length2();
        if (n2 > 0) {
            T inv = 1 / sqrt(n2);  // ::sqrt(double): the division happens in double
            x *= inv, y *= inv, z *= inv;
        }
        return *this;
    }
    T dot(const Vec3 &v) const { return x * v.x + y * v.y + z * v.z; }
    Vec3 operator*(const T &f) const { return Vec3(x * f, y * f, z * f); }
    Vec3 operator*(const Vec3 &v) const { return Vec3(x * v.x, y * v.y, z * v.z); }
    Vec3 operator+(const Vec3 &v) const { return Vec3(x + v.x, y + v.y, z + v.z); }
    Vec3 operator-(const Vec3 &v) const { return Vec3(x - v.x, y - v.y, z - v.z); }
    Vec3 operator-() const { return Vec3(-x, -y, -z); }
    Vec3 &operator+=(const Vec3 &v) {
        x += v.x, y += v.y, z += v.z;
        return *this;
    }
};
typedef Vec3<float> Vec3f;

struct Ball {
    Vec3f centre;
    float radius, radius2;
    Vec3f surface, emission;
    float transparency, reflection, ior;
    Ball(const Vec3f &c, float r, const Vec3f &col, float refl, float transp, float index,
         const Vec3f &emit = Vec3f(0))
        : centre(c), radius(r), radius2(r * r), surface(col), emission(emit),
          transparency(transp), reflection(refl), ior(index) {}
    // Geometric test: entry distance t0 and exit distance t1 along a unit direction.
    bool hit(const Vec3f &orig, const Vec3f &dir, float &t0, float &t1) const {
        Vec3f l = centre - orig;
        float tca = l.dot(dir);
        if (tca < 0) return false;
        float d2 = l.dot(l) - tca * tca;
        if (d2 > radius2) return false;
        float thc = sqrt(radius2 - d2);
        t0 = tca - thc;
        t1 = tca + thc;
        return true;
    }
};

static float blend(const float &a, const float &b, const float &w) { return b * w + a * (1 - w); }

static std::vector<Ball> world;

Vec3f trace(const Vec3f &orig, const Vec3f &dir, const int &depth) {
    float nearest = INFINITY;
    const Ball *ball = NULL;
    for (unsigned i = 0; i < world.size(); ++i) {
        float t0 = INFINITY, t1 = INFINITY;
        if (world[i].hit(orig, dir, t0, t1)) {
            if (t0 < 0) t0 = t1;
            if (t0 < nearest) {
                nearest = t0;
                ball = &world[i];
            }
        }
    }
#ifdef BLACK_BACKGROUND
    if (!ball) return Vec3f(0);
#else
    if (!ball) return Vec3f(2);
#endif
    Vec3f colour = 0;
    Vec3f phit = orig + dir * nearest;
    Vec3f nhit = phit - ball->centre;
    nhit.normalize();
#ifdef NO_BIAS
    float bias = 0;
#else
    float bias = 1e-4;
#endif
    bool inside = false;
    if (dir.dot(nhit) > 0) {
#ifndef NO_INSIDE_FLIP
        nhit = -nhit;
#endif
        inside = true;
    }
    if ((ball->transparency > 0 || ball->reflection > 0) && depth < MAX_RAY_DEPTH) {
        float facing = -dir.dot(nhit);
        if (facing < 0) facing = 0;
#ifdef FRESNEL_SQUARE
        float fresnel = blend(pow(1 - facing, 2), 1, 0.1);
#else
        float fresnel = blend(pow(1 - facing, 3), 1, 0.1);
#endif
        Vec3f rdir = dir - nhit * 2 * dir.dot(nhit);
        rdir.normalize();
        Vec3f reflection = trace(phit + nhit * bias, rdir, depth + 1);
        Vec3f refraction = 0;
        if (ball->transparency) {
#ifdef ETA_INVERTED
            float eta = inside ? 1 / ball->ior : ball->ior;
#else
            float eta = inside ? ball->ior : 1 / ball->ior;
#endif
            float cosi = -nhit.dot(dir);
            float k = 1 - eta * eta * (1 - cosi * cosi);
            Vec3f tdir = dir * eta + nhit * (eta * cosi - sqrt(k));
            tdir.normalize();
            refraction = trace(phit - nhit * bias, tdir, depth + 1);
        }
        colour = reflection * fresnel + refraction * (1 - fresnel) * ball->transparency;
#ifdef UNTINTED_GLASS
        if (!ball->transparency) colour = colour * ball->surface;
#else
        colour = colour * ball->surface;
#endif
    } else {
        for (unsigned i = 0; i < world.size(); ++i) {
            if (world[i].emission.x > 0) {
                Vec3f transmission = 1;
                Vec3f towards = world[i].centre - phit;
                towards.normalize();
                for (unsigned j = 0; j < world.size(); ++j) {
                    if (i == j) continue;
                    float t0, t1;
                    if (world[j].hit(phit + nhit * bias, towards, t0, t1)) {
                        transmission = 0;
                        break;
                    }
                }
                colour += ball->surface * transmission * std::max(float(0), nhit.dot(towards)) *
                          world[i].emission;
            }
        }
    }
    return colour + ball->emission;
}

int main(int argc, char **argv) {
    if (argc != 4) {
        std::fprintf(stderr, "usage: %s WIDTH HEIGHT OUT.ppm\n", argv[0]);
        return 64;
    }
    unsigned width = std::atoi(argv[1]), height = std::atoi(argv[2]);
    if (width < 1 || height < 1) return 64;
    world.push_back(Ball(Vec3f(0.0, -10004, -20), 10000, Vec3f(0.20, 0.20, 0.20), 0, 0.0, 1));
    world.push_back(Ball(Vec3f(0.0, 0, -20), 4, Vec3f(1.00, 0.32, 0.36), 1, 0.5, GLASS_IOR));
    world.push_back(Ball(Vec3f(5.0, -1, -15), 2, Vec3f(0.90, 0.76, 0.46), 1, 0.0, 1));
    world.push_back(Ball(Vec3f(5.0, 0, -25), 3, Vec3f(0.65, 0.77, 0.97), 1, 0.0, 1));
    world.push_back(Ball(Vec3f(-5.5, 0, -15), 3, Vec3f(0.90, 0.90, 0.90), 1, 0.0, 1));
    world.push_back(Ball(Vec3f(0.0, 20, -30), 3, Vec3f(0.00, 0.00, 0.00), 0, 0.0, 1, Vec3f(3)));

    Vec3f *image = new Vec3f[width * height], *pixel = image;
    float invWidth = 1 / float(width), invHeight = 1 / float(height);
    float fov = 30, aspectratio = width / float(height);
    float angle = tan(M_PI * 0.5 * fov / 180.);
#ifdef PIXEL_CORNERS
    const float centre = 0;
#else
    const float centre = 0.5;
#endif
    for (unsigned y = 0; y < height; ++y) {
        for (unsigned x = 0; x < width; ++x, ++pixel) {
            float xx = (2 * ((x + centre) * invWidth) - 1) * angle * aspectratio;
            float yy = (1 - 2 * ((y + centre) * invHeight)) * angle;
            Vec3f raydir(xx, yy, -1);
            raydir.normalize();
            *pixel = trace(Vec3f(0), raydir, 0);
        }
    }
    std::ofstream ofs(argv[3], std::ios::out | std::ios::binary);
    ofs << "P6\n" << width << " " << height << "\n255\n";
    for (unsigned i = 0; i < width * height; ++i) {
        ofs << (unsigned char)(std::min(float(1), image[i].x) * 255)
            << (unsigned char)(std::min(float(1), image[i].y) * 255)
            << (unsigned char)(std::min(float(1), image[i].z) * 255);
    }
    ofs.close();
    delete[] image;
    return ofs ? 0 : 1;
}
