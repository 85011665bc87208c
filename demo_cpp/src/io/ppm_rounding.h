#pragma once

namespace rt {

// How a linear value in [0, 1] becomes a byte: `truncate` is what the paper's program family
// writes, (unsigned char)(std::min(1.f, x) * 255); `round` is the nearest level.
enum class PpmRounding { truncate, round };

}  // namespace rt
