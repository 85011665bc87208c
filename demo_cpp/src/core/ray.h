#pragma once

#include "core/vec3.h"

namespace rt {

// A ray; `dir` is unit length everywhere in the demo, so t is a distance.
struct ray {
    point3 origin;
    vec3 dir;
    point3 at(float t) const { return origin + dir * t; }
};

}  // namespace rt
