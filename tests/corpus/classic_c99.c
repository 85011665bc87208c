/* The classic Whitted program (docs/paper-model.md, `classic` mode) as a C99 student writes
 * it: a plain struct of three floats with small functions, float maths throughout (sqrtf,
 * powf, tanf), a table of spheres, an explicit recursion, and a rounding PPM writer
 * (int)(x * 255 + 0.5) after clamping to [0, 1]. Independent code written for rtval's corpus
 * from the model's description; the scene (scenes/classic.json) is hard-coded.
 *
 *   classic_c99 WIDTH HEIGHT OUT.ppm
 *
 * -DMAX_DEPTH=N changes the recursion limit (the scene asks for 5).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#ifndef MAX_DEPTH
#define MAX_DEPTH 5
#endif

typedef struct {
    float x, y, z;
} vec3;

static vec3 v3(float x, float y, float z) {
    vec3 v;
    v.x = x;
    v.y = y;
    v.z = z;
    return v;
}
static vec3 add(vec3 a, vec3 b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static vec3 sub(vec3 a, vec3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static vec3 mul(vec3 a, vec3 b) { return v3(a.x * b.x, a.y * b.y, a.z * b.z); }
static vec3 scale(vec3 a, float s) { return v3(a.x * s, a.y * s, a.z * s); }
static float dot(vec3 a, vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static vec3 unit(vec3 a) {
    float len = sqrtf(dot(a, a));
    return len > 0 ? v3(a.x / len, a.y / len, a.z / len) : a;
}

typedef struct {
    vec3 centre;
    float radius;
    vec3 colour;
    float reflection, transparency, ior;
    vec3 emission;
} sphere;

#define NSPHERES 6
static const sphere scene[NSPHERES] = {
    {{0.0f, -10004.0f, -20.0f}, 10000.0f, {0.2f, 0.2f, 0.2f}, 0.0f, 0.0f, 1.0f, {0, 0, 0}},
    {{0.0f, 0.0f, -20.0f}, 4.0f, {1.0f, 0.32f, 0.36f}, 1.0f, 0.5f, 1.1f, {0, 0, 0}},
    {{5.0f, -1.0f, -15.0f}, 2.0f, {0.90f, 0.76f, 0.46f}, 1.0f, 0.0f, 1.0f, {0, 0, 0}},
    {{5.0f, 0.0f, -25.0f}, 3.0f, {0.65f, 0.77f, 0.97f}, 1.0f, 0.0f, 1.0f, {0, 0, 0}},
    {{-5.5f, 0.0f, -15.0f}, 3.0f, {0.90f, 0.90f, 0.90f}, 1.0f, 0.0f, 1.0f, {0, 0, 0}},
    {{0.0f, 20.0f, -30.0f}, 3.0f, {0.0f, 0.0f, 0.0f}, 0.0f, 0.0f, 1.0f, {3.0f, 3.0f, 3.0f}},
};
static const vec3 BACKGROUND = {2.0f, 2.0f, 2.0f};
static const float BIAS = 1e-4f;

/* Distance to the sphere along a unit direction, or -1 for a miss. */
static float intersect(const sphere *s, vec3 o, vec3 d) {
    vec3 l = sub(s->centre, o);
    float tca = dot(l, d), d2, thc, t;
    if (tca < 0) return -1;
    d2 = dot(l, l) - tca * tca;
    if (d2 > s->radius * s->radius) return -1;
    thc = sqrtf(s->radius * s->radius - d2);
    t = tca - thc;
    if (t < 0) t = tca + thc;
    return t;
}

static vec3 trace(vec3 o, vec3 d, int depth) {
    int i, j, hit = -1;
    float tmin = INFINITY;
    const sphere *s;
    vec3 p, n, c = v3(0, 0, 0);
    int inside = 0;

    for (i = 0; i < NSPHERES; i++) {
        float t = intersect(&scene[i], o, d);
        if (t >= 0 && t < tmin) {
            tmin = t;
            hit = i;
        }
    }
    if (hit < 0) return BACKGROUND;
    s = &scene[hit];
    p = add(o, scale(d, tmin));
    n = unit(sub(p, s->centre));
    if (dot(d, n) > 0) {
        n = scale(n, -1);
        inside = 1;
    }
    if ((s->transparency > 0 || s->reflection > 0) && depth < MAX_DEPTH) {
        float facing = fmaxf(0.0f, -dot(d, n));
        float fr = 0.1f + 0.9f * powf(1.0f - facing, 3.0f);
        vec3 r = unit(sub(d, scale(n, 2.0f * dot(d, n))));
        vec3 refl = trace(add(p, scale(n, BIAS)), r, depth + 1);
        vec3 refr = v3(0, 0, 0);
        if (s->transparency > 0) {
            float eta = inside ? s->ior : 1.0f / s->ior;
            float cosi = -dot(n, d);
            float k = 1.0f - eta * eta * (1.0f - cosi * cosi);
            vec3 t = unit(add(scale(d, eta), scale(n, eta * cosi - sqrtf(k))));
            refr = trace(sub(p, scale(n, BIAS)), t, depth + 1);
        }
        c = mul(add(scale(refl, fr), scale(refr, (1.0f - fr) * s->transparency)), s->colour);
    } else {
        for (i = 0; i < NSPHERES; i++) {
            vec3 l;
            float lit = 1.0f;
            if (scene[i].emission.x <= 0) continue;
            l = unit(sub(scene[i].centre, p));
            for (j = 0; j < NSPHERES; j++) {
                if (j != i && intersect(&scene[j], add(p, scale(n, BIAS)), l) >= 0) {
                    lit = 0.0f;
                    break;
                }
            }
            c = add(c, scale(mul(s->colour, scene[i].emission), lit * fmaxf(0.0f, dot(n, l))));
        }
    }
    return add(c, s->emission);
}

static unsigned char to_byte(float v) {
    if (!(v > 0)) return 0; /* also NaN */
    if (v > 1) v = 1;
    return (unsigned char)(int)(v * 255 + 0.5f);
}

int main(int argc, char **argv) {
    int w, h, x, y;
    float half, aspect;
    unsigned char *img;
    FILE *f;
    if (argc != 4) {
        fprintf(stderr, "usage: %s WIDTH HEIGHT OUT.ppm\n", argv[0]);
        return 64;
    }
    w = atoi(argv[1]);
    h = atoi(argv[2]);
    if (w < 1 || h < 1) return 64;
    half = tanf(30.0f * 0.5f * 3.14159265f / 180.0f);
    aspect = (float)w / (float)h;
    img = malloc((size_t)w * h * 3);
    if (!img) return 1;
    for (y = 0; y < h; y++) {
        for (x = 0; x < w; x++) {
            float px = (2.0f * (x + 0.5f) / w - 1.0f) * half * aspect;
            float py = (1.0f - 2.0f * (y + 0.5f) / h) * half;
            vec3 c = trace(v3(0, 0, 0), unit(v3(px, py, -1.0f)), 0);
            unsigned char *q = img + ((size_t)y * w + x) * 3;
            q[0] = to_byte(c.x);
            q[1] = to_byte(c.y);
            q[2] = to_byte(c.z);
        }
    }
    f = fopen(argv[3], "wb");
    if (!f) return 1;
    fprintf(f, "P6\n%d %d\n255\n", w, h);
    fwrite(img, 1, (size_t)w * h * 3, f);
    free(img);
    return fclose(f) == 0 ? 0 : 1;
}
