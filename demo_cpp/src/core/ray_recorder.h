// A listener the scalar tracer tells what each ray does (rtdemo trace-pixel, the path AOV).
// The tracer holds a pointer to one, null in normal renders: each event is then one untaken
// branch, so the render's speed is unchanged.
#pragma once

#include "core/ray.h"

namespace rt {

enum class RayKind { camera, reflection, refraction };

class RayRecorder {
public:
    virtual ~RayRecorder() = default;
    // A ray starts (the camera ray, or one spawned at the surface of the ray before it).
    virtual void begin_ray(RayKind kind, const ray& r, int depth) = 0;
    // The ray's nearest hit: sphere index and distance (no call: the ray missed).
    virtual void hit(int sphere, float t) = 0;
    // The surface is shaded with normal n (as the tracer uses it); depth_limit: a specular
    // surface reached at max depth.
    virtual void surface(const vec3& n, bool inside, bool depth_limit) = 0;
    // A specular surface's reflection weight (1 at total internal reflection).
    virtual void specular(float fresnel, bool total_internal) = 0;
    // A sphere blocks the shadow ray now being cast (before its light_sample).
    virtual void blocker(int sphere) = 0;
    // A light tested at a diffuse point: its direction, Lambert term and transmission.
    virtual void light_sample(int light, const vec3& dir, float lambert, float transmission) = 0;
    // The ray returns colour c.
    virtual void end_ray(const color& c) = 0;
};

}  // namespace rt
