#pragma once

#include <limits>

namespace rt {

// An open range of ray parameters (min, max). Shadow rays use max = distance to the light.
struct interval {
    float min = 0.0f;
    float max = std::numeric_limits<float>::infinity();
    constexpr bool surrounds(float t) const { return min < t && t < max; }
};

}  // namespace rt
