// Named common mistakes of a Whitted ray tracer as run-time switches (--mistake NAME), so that
// `rtval diagnose` can render what a program with that mistake shows and `rtval check` can be
// tested against a broken build. The names and explanations live in one file,
// compare/judge/mistakes.json, embedded at build time and read by the Python side too.
#pragma once

#include <bitset>
#include <string>
#include <vector>

namespace rt {

enum class Mistake {
    no_offset,          // secondary and shadow rays start exactly on the surface
    no_inside_flip,     // the normal is not flipped when the ray is inside a sphere
    eta_inverted,       // the index ratio the wrong way up at both crossings
    shadow_past_light,  // shadow rays not stopped at the light (= quirk Q5)
    fresnel_missing,    // reflection and refraction added at full strength
    fresnel_constant,   // Fresnel weight 0.5 at every angle
    fresnel_exponent,   // (1 - cos)^2 in the paper's Fresnel curve
    black_background,   // a miss returns black
    flipped_normal,     // the shading normal points into the surface
    half_pixel_offset,  // camera rays through pixel corners
    double_gamma,       // x^(1/2.2) before the output is written
    depth_cut,          // the recursion stops one level early
    no_shadows,         // shadow rays never blocked
};
constexpr int kMistakeCount = 13;

class MistakeSet {
public:
    bool has(Mistake m) const { return bits_.test(static_cast<std::size_t>(m)); }
    void add(Mistake m) { bits_.set(static_cast<std::size_t>(m)); }
    void remove(Mistake m) { bits_.reset(static_cast<std::size_t>(m)); }
    bool any() const { return bits_.any(); }
    // "no_offset,double_gamma" in catalogue order, "none" when empty.
    std::string list() const;

private:
    std::bitset<kMistakeCount> bits_;
};

struct MistakeInfo {
    std::string name, explanation;
};

// The catalogue in the embedded JSON's order; every entry has a Mistake of the same name
// (checked by mistakes_test.cpp).
const std::vector<MistakeInfo>& mistake_catalogue();
const char* mistake_name(Mistake m);
// "no_offset,double_gamma" -> set; throws std::invalid_argument naming an unknown name.
MistakeSet parse_mistake_list(const std::string& text);

}  // namespace rt
