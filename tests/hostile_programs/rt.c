/* A tiny correct renderer for the sandbox tests (tests/test_grade_programs.py): the classic
 * Whitted model of scenes/classic.json (the algorithm of tests/foreign/classic_tracer.cpp,
 * ported to C so that a class of them builds in a blink), hard-coded: it ignores the scene.
 *
 *   rt OUT.ppm WIDTH HEIGHT [SCENE]     (OUT "-": writes untitled.ppm, as scratchapixel does)
 *
 * student.h, beside it, is what makes one student differ: it defines HOOK_START (run first),
 * HOOK_BEFORE_WRITE and HOOK_AFTER_WRITE (around writing OUT), and may set `broken` to make
 * the image wrong. The correct student's student.h defines them empty.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct { float x, y, z; } Vec;
static Vec add(Vec a, Vec b) { Vec r = {a.x + b.x, a.y + b.y, a.z + b.z}; return r; }
static Vec sub(Vec a, Vec b) { Vec r = {a.x - b.x, a.y - b.y, a.z - b.z}; return r; }
static Vec scale(Vec a, float s) { Vec r = {a.x * s, a.y * s, a.z * s}; return r; }
static Vec mul(Vec a, Vec b) { Vec r = {a.x * b.x, a.y * b.y, a.z * b.z}; return r; }
static float dot(Vec a, Vec b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static Vec unit(Vec a) {
    float n = sqrtf(dot(a, a));
    return n > 0 ? scale(a, 1 / n) : a;
}

typedef struct { Vec c; float r; Vec colour, emission; float reflection, transparency; } Ball;
static const Ball balls[] = {
    {{0, -10004, -20}, 10000, {0.2f, 0.2f, 0.2f}, {0, 0, 0}, 0, 0},
    {{0, 0, -20}, 4, {1.0f, 0.32f, 0.36f}, {0, 0, 0}, 1, 0.5f},
    {{5, -1, -15}, 2, {0.90f, 0.76f, 0.46f}, {0, 0, 0}, 1, 0},
    {{5, 0, -25}, 3, {0.65f, 0.77f, 0.97f}, {0, 0, 0}, 1, 0},
    {{-5.5f, 0, -15}, 3, {0.90f, 0.90f, 0.90f}, {0, 0, 0}, 1, 0},
    {{0, 20, -30}, 3, {0, 0, 0}, {3, 3, 3}, 0, 0},
};
enum { N_BALLS = sizeof balls / sizeof balls[0], MAX_DEPTH = 5 };
static const float BIAS = 1e-4f, IOR = 1.1f;
static int broken = 0; /* a hook sets it: the image comes out wrong */

static int hit(const Ball *b, Vec o, Vec d, float *t) {
    Vec l = sub(b->c, o);
    float tca = dot(l, d);
    if (tca < 0) return 0;
    float d2 = dot(l, l) - tca * tca;
    if (d2 > b->r * b->r) return 0;
    float thc = sqrtf(b->r * b->r - d2);
    float t0 = tca - thc;
    *t = t0 < 0 ? tca + thc : t0;
    return 1;
}

static Vec trace(Vec o, Vec d, int depth) {
    float near = INFINITY, t;
    const Ball *b = NULL;
    for (int i = 0; i < N_BALLS; ++i)
        if (hit(&balls[i], o, d, &t) && t < near) near = t, b = &balls[i];
    if (!b) { Vec bg = {2, 2, 2}; return bg; }
    Vec p = add(o, scale(d, near)), n = unit(sub(p, b->c));
    int inside = dot(d, n) > 0;
    if (inside) n = scale(n, -1);
    Vec colour = {0, 0, 0};
    if ((b->transparency > 0 || b->reflection > 0) && depth < MAX_DEPTH) {
        float facing = -dot(d, n);
        float fresnel = 0.1f + 0.9f * powf(1 - facing, 3.0f);
        Vec r = unit(sub(d, scale(n, 2 * dot(d, n))));
        Vec refl = trace(add(p, scale(n, BIAS)), r, depth + 1), refr = {0, 0, 0};
        if (b->transparency > 0) {
            float eta = inside ? IOR : 1 / IOR, cosi = -dot(n, d);
            float k = 1 - eta * eta * (1 - cosi * cosi);
            Vec tr = unit(add(scale(d, eta), scale(n, eta * cosi - sqrtf(k))));
            refr = trace(sub(p, scale(n, BIAS)), tr, depth + 1);
        }
        colour = mul(add(scale(refl, fresnel), scale(refr, (1 - fresnel) * b->transparency)),
                     b->colour);
    } else {
        for (int i = 0; i < N_BALLS; ++i) {
            if (balls[i].emission.x <= 0) continue;
            Vec l = unit(sub(balls[i].c, p));
            float transmission = 1;
            for (int j = 0; j < N_BALLS; ++j)
                if (j != i && hit(&balls[j], add(p, scale(n, BIAS)), l, &t)) {
                    transmission = 0;
                    break;
                }
            float lambert = dot(n, l) > 0 ? dot(n, l) : 0;
            colour = add(colour, scale(mul(b->colour, balls[i].emission), transmission * lambert));
        }
    }
    return add(colour, b->emission);
}

#include "student.h"

int main(int argc, char **argv) {
    if (argc < 4) {
        fprintf(stderr, "usage: rt OUT.ppm WIDTH HEIGHT [SCENE]\n");
        return 64;
    }
    HOOK_START
    const char *out = strcmp(argv[1], "-") == 0 ? "untitled.ppm" : argv[1];
    int w = atoi(argv[2]), h = atoi(argv[3]);
    if (w < 1 || h < 1) return 64;
    float angle = tanf(3.14159265358979f * 0.5f * 30 / 180), aspect = (float)w / h;
    unsigned char *px = malloc((size_t)w * h * 3);
    if (!px) return 1;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            Vec d = {(2 * ((x + 0.5f) / w) - 1) * angle * aspect,
                     (1 - 2 * ((y + 0.5f) / h)) * angle, -1};
            Vec o = {0, 0, 0};
            Vec c = trace(o, unit(d), 0);
            float v[3] = {c.x, c.y, c.z};
            for (int k = 0; k < 3; ++k) {
                float f = isnan(v[k]) ? 0 : fminf(1.f, fmaxf(0.f, v[k]));
                px[((size_t)y * w + x) * 3 + k] = broken ? 0 : (unsigned char)(f * 255 + 0.5f);
            }
        }
    HOOK_BEFORE_WRITE
    FILE *f = fopen(out, "wb");
    if (!f) return 1;
    fprintf(f, "P6\n%d %d\n255\n", w, h);
    fwrite(px, 1, (size_t)w * h * 3, f);
    if (fclose(f) != 0) return 1;
    HOOK_AFTER_WRITE
    return 0;
}
