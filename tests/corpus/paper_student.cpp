// The course paper's program (docs/paper-model.md, `paper` mode: quirks Q1-Q13) as a student
// types it from the paper's listing: a hand-written Vec3f, `using namespace std`, so
// `pow(1 - facingratio, 3)` is std::pow(float, int), computed in double; one shadow factor
// for all lights held in a `double` (Q4) that glass only partly lowers (Q9); `eta = 1 / ior`
// on both sides of the glass (Q2); the directly lit colour starts at 1
// (`Vec3f surfaceColor = 1;`, Q11), each light adds `colour * transmission * emission` with no
// cosine and a shadow ray towards every light (Q12), and the hit sphere's emission is never
// added (Q13); a truncating PPM writer. Independent code written for rtval's corpus from the
// model's description. Two scenes are hard-coded: the paper's own (scenes/paper.json) and
// rtval's lit variant (scenes/lit.json, a look-at camera).
//
//   paper_student paper|lit WIDTH HEIGHT OUT.ppm [--mirror | --look-at-as-direction]
//
// --mirror writes the picture as the paper's OpenGL window shows it: pixel x drawn at
// x_ndc = -2 (x / W - 0.5), i.e. mirrored left to right. --look-at-as-direction is the
// look-at slip people ask about: the camera looks along lookAt itself, the eye not
// subtracted (the same camera wherever the eye is the origin, as in the paper's scene).
//
// Built with -DC_STYLE it is written as scratchapixel's C-flavoured code is: the square roots
// of C's <math.h> (the float promoted to double, the result narrowed back) and a PPM writer
// that rounds instead of truncating. Both are correct; the float chains differ.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <vector>

#ifdef C_STYLE
#define sqrt(x) (float(::sqrt(double(x))))
#define CODE(v) (unsigned char)(min(float(1), v) * 255 + 0.5f)
#else
#define CODE(v) (unsigned char)(min(float(1), v) * 255)
#endif
using namespace std;

class Vec3f {
public:
    float x, y, z;
    Vec3f() : x(0), y(0), z(0) {}
    Vec3f(float v) : x(v), y(v), z(v) {}
    Vec3f(float a, float b, float c) : x(a), y(b), z(c) {}
    Vec3f operator+(const Vec3f &v) const { return Vec3f(x + v.x, y + v.y, z + v.z); }
    Vec3f operator-(const Vec3f &v) const { return Vec3f(x - v.x, y - v.y, z - v.z); }
    Vec3f operator*(const float &f) const { return Vec3f(x * f, y * f, z * f); }
    Vec3f operator*(const Vec3f &v) const { return Vec3f(x * v.x, y * v.y, z * v.z); }
    Vec3f operator-() const { return Vec3f(-x, -y, -z); }
    Vec3f &operator+=(const Vec3f &v) {
        x += v.x, y += v.y, z += v.z;
        return *this;
    }
    float dot(const Vec3f &v) const { return x * v.x + y * v.y + z * v.z; }
    Vec3f cross(const Vec3f &v) const {
        return Vec3f(y * v.z - z * v.y, z * v.x - x * v.z, x * v.y - y * v.x);
    }
    Vec3f &normalize() {
        float len2 = dot(*this);
        if (len2 > 0) {
            float inv = 1 / sqrt(len2);
            x *= inv, y *= inv, z *= inv;
        }
        return *this;
    }
};

struct Sphere {
    Vec3f center;
    float radius, radius2;
    Vec3f surfaceColor, emissionColor;
    float transparency, reflection;
    Sphere(const Vec3f &c, const float &r, const Vec3f &sc, const float &refl,
           const float &transp, const Vec3f &ec = 0)
        : center(c), radius(r), radius2(r * r), surfaceColor(sc), emissionColor(ec),
          transparency(transp), reflection(refl) {}
    bool intersect(const Vec3f &rayorig, const Vec3f &raydir, float &t0, float &t1) const {
        Vec3f l = center - rayorig;
        float tca = l.dot(raydir);
        if (tca < 0) return false;
        float d2 = l.dot(l) - tca * tca;
        if (d2 > radius2) return false;
        float thc = sqrt(radius2 - d2);
        t0 = tca - thc;
        t1 = tca + thc;
        return true;
    }
};

struct World {
    vector<Sphere> spheres;
    Vec3f background;
    int maxDepth;
    float fov;
    Vec3f eye, lookAt;
};

static const float kBias = 1e-4;
static const float kIor = 1.2;  // every glass sphere of both scenes

float mix(const float &a, const float &b, const float &m) { return b * m + a * (1 - m); }

Vec3f trace(const World &w, const Vec3f &rayorig, const Vec3f &raydir, const int &depth) {
    float tnear = INFINITY;
    const Sphere *sphere = NULL;
    for (unsigned i = 0; i < w.spheres.size(); ++i) {
        float t0 = INFINITY, t1 = INFINITY;
        if (w.spheres[i].intersect(rayorig, raydir, t0, t1)) {
            if (t0 < 0) t0 = t1;
            if (t0 < tnear) {
                tnear = t0;
                sphere = &w.spheres[i];
            }
        }
    }
    if (!sphere) return w.background;
    Vec3f phit = rayorig + raydir * tnear;
    Vec3f nhit = phit - sphere->center;
    nhit.normalize();
    bool inside = false;
    if (raydir.dot(nhit) > 0) nhit = -nhit, inside = true;
    (void)inside;  // the paper keeps eta = 1 / ior on the way out too
    if ((sphere->transparency > 0 || sphere->reflection > 0) && depth < w.maxDepth) {
        float facingratio = -raydir.dot(nhit);
        float fresneleffect = mix(pow(1 - facingratio, 3), 1, 0.1);
        Vec3f refldir = raydir - nhit * 2 * raydir.dot(nhit);
        refldir.normalize();
        Vec3f reflection = trace(w, phit + nhit * kBias, refldir, depth + 1);
        Vec3f refraction = 0;
        if (sphere->transparency) {
            float eta = 1 / kIor;
            float cosi = -nhit.dot(raydir);
            float k = 1 - eta * eta * (1 - cosi * cosi);
            Vec3f refrdir = raydir * eta + nhit * (eta * cosi - sqrt(k));
            refrdir.normalize();
            refraction = trace(w, phit - nhit * kBias, refrdir, depth + 1);
        }
        return (reflection * fresneleffect + refraction * (1 - fresneleffect) * sphere->transparency) *
               sphere->surfaceColor;
    }
    Vec3f surfaceColor = 1;
    double shadow = 1;
    for (unsigned i = 0; i < w.spheres.size(); ++i) {
        if (w.spheres[i].emissionColor.x > 0) {
            float transmission = 1;
            Vec3f lightDirection = w.spheres[i].center - phit;
            lightDirection.normalize();
            for (unsigned j = 0; j < w.spheres.size(); ++j) {
                if (i != j) {
                    float t0, t1;
                    if (w.spheres[j].intersect(phit + nhit * kBias, lightDirection, t0, t1)) {
                        shadow = max(0.0, shadow - (1.0 - w.spheres[j].transparency));
                        transmission *= shadow;
                    }
                }
            }
            surfaceColor += sphere->surfaceColor * transmission * w.spheres[i].emissionColor;
        }
    }
    return surfaceColor;
}

static World paperScene() {
    World w;
    w.spheres.push_back(Sphere(Vec3f(0.0, -10004, -20), 10000, Vec3f(1.00, 1.00, 1.00), 1.0, 0.0));
    w.spheres.push_back(Sphere(Vec3f(6.0, 0, -15), 1.5, Vec3f(1.00, 0.10, 0.10), 0.2, 0.95));
    w.spheres.push_back(Sphere(Vec3f(7.5, 2.5, -25), 2, Vec3f(0.10, 0.10, 1.00), 0.2, 0.7));
    w.spheres.push_back(Sphere(Vec3f(1.0, -1, -18), 1, Vec3f(1.00, 1.00, 1.00), 0.1, 1.0));
    w.spheres.push_back(Sphere(Vec3f(2.0, 1, -25), 2, Vec3f(1.00, 1.00, 1.00), 0.3, 0.0));
    w.spheres.push_back(Sphere(Vec3f(-2.0, 2, -15), 1, Vec3f(1.00, 1.00, 0.10), 0.5, 0.5));
    w.spheres.push_back(Sphere(Vec3f(-4.0, 3, -18), 1, Vec3f(0.10, 1.00, 0.10), 0.3, 0.7));
    w.spheres.push_back(Sphere(Vec3f(-8.0, 0, -25), 0.5, Vec3f(0.36, 0.84, 1.00), 0.15, 0.95));
    w.spheres.push_back(Sphere(Vec3f(-8.5, -1.5, -25), 1, Vec3f(1.00, 0.10, 0.10), 0.15, 0.5));
    w.background = Vec3f(1);
    w.maxDepth = 10;
    w.fov = 40;
    w.eye = Vec3f(0);
    w.lookAt = Vec3f(0, 0, -1);
    return w;
}

static World litScene() {
    World w;
    w.spheres.push_back(Sphere(Vec3f(0.0, -10004, -20), 10000, Vec3f(1.00, 1.00, 1.00), 1, 0.0));
    w.spheres.push_back(Sphere(Vec3f(0.0, -2, -18), 2, Vec3f(0.90, 0.95, 1.00), 1, 0.8));
    w.spheres.push_back(Sphere(Vec3f(-4.5, -2.5, -20), 1.5, Vec3f(1.00, 0.32, 0.36), 0, 0.0));
    w.spheres.push_back(Sphere(Vec3f(4.2, -2.5, -19), 1.5, Vec3f(0.90, 0.76, 0.46), 1, 0.0));
    w.spheres.push_back(Sphere(Vec3f(2.2, -3.0, -24), 1, Vec3f(0.65, 0.77, 0.97), 0, 0.0));
    w.spheres.push_back(Sphere(Vec3f(-2.4, -2.8, -14), 1.2, Vec3f(0.45, 0.85, 0.50), 0, 0.0));
    w.spheres.push_back(Sphere(Vec3f(-1.5, -2.0, -26), 2, Vec3f(0.75, 0.60, 0.95), 1, 0.0));
    w.spheres.push_back(Sphere(Vec3f(-10, 14, -8), 2, Vec3f(0), 0, 0.0, Vec3f(2.5)));
    w.background = Vec3f(2);
    w.maxDepth = 5;
    w.fov = 30;
    w.eye = Vec3f(0, 1, 4);
    w.lookAt = Vec3f(0, -1.5, -18);
    return w;
}

int main(int argc, char **argv) {
    bool mirror = argc == 6 && strcmp(argv[5], "--mirror") == 0;
    bool lookAtAsDirection = argc == 6 && strcmp(argv[5], "--look-at-as-direction") == 0;
    if (argc != 5 && !mirror && !lookAtAsDirection) {
        fprintf(stderr, "usage: %s paper|lit WIDTH HEIGHT OUT.ppm [--mirror | --look-at-as-direction]\n",
                argv[0]);
        return 64;
    }
    World world;
    if (strcmp(argv[1], "paper") == 0)
        world = paperScene();
    else if (strcmp(argv[1], "lit") == 0)
        world = litScene();
    else
        return 64;
    unsigned width = atoi(argv[2]), height = atoi(argv[3]);
    if (width < 1 || height < 1) return 64;

    // The camera's frame: forward, right = forward x up, up' = right x forward.
    Vec3f forward = lookAtAsDirection ? world.lookAt : world.lookAt - world.eye;
    forward.normalize();
    Vec3f right = forward.cross(Vec3f(0, 1, 0));
    right.normalize();
    Vec3f up = right.cross(forward);

    vector<Vec3f> image(width * height);
    float invWidth = 1 / float(width), invHeight = 1 / float(height);
    float aspectratio = width / float(height);
    float angle = tan(M_PI * 0.5 * world.fov / 180.);
    for (unsigned y = 0; y < height; ++y) {
        for (unsigned x = 0; x < width; ++x) {
            float xx = (2 * ((x + 0.5) * invWidth) - 1) * angle * aspectratio;
            float yy = (1 - 2 * ((y + 0.5) * invHeight)) * angle;
            Vec3f raydir = right * xx + up * yy + forward;
            raydir.normalize();
            image[y * width + x] = trace(world, world.eye, raydir, 0);
        }
    }
    ofstream ofs(argv[4], ios::out | ios::binary);
    ofs << "P6\n" << width << " " << height << "\n255\n";
    for (unsigned y = 0; y < height; ++y) {
        for (unsigned x = 0; x < width; ++x) {
            // The window draws pixel x at x_ndc = -2 (x / W - 0.5): column W - 1 - x.
            const Vec3f &c = image[y * width + (mirror ? width - 1 - x : x)];
            ofs << CODE(c.x) << CODE(c.y) << CODE(c.z);
        }
    }
    ofs.close();
    return ofs ? 0 : 1;
}
