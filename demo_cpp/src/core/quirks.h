// The paper's quirks Q1-Q13 (docs/paper-model.md) as switches, and the three modes as presets.
#pragma once

#include <bitset>
#include <string>
#include <vector>

namespace rt {

// Each quirk by what it does; its number is its label ("Q7") in docs, flags and headers.
// RT_QUIRK_LIST(X) is X(name, number) for each: the enum, the packet engine's named flags
// and their filling are made from it, so a quirk is one line here and its code.
#define RT_QUIRK_LIST(X)                                                                          \
    X(paper_intersection, 1)               /* Q1: the tca < 0 early-out and a fixed bias */       \
    X(eta_one_over_ior_leaving, 2)         /* Q2: eta = 1/ior also when leaving glass */          \
    X(nan_at_total_internal_reflection, 3) /* Q3: a NaN direction at total internal reflection */ \
    X(shared_shadow_factor, 4)             /* Q4: one shadow factor shared by all lights */       \
    X(shadow_rays_pass_light, 5)           /* Q5: shadow rays not stopped at the light */         \
    X(diffuse_at_max_depth, 6)      /* Q6: specular surfaces shaded as diffuse at max depth */    \
    X(no_pi_no_falloff, 7)          /* Q7: no 1/pi and no distance falloff */                     \
    X(paper_fresnel, 8)             /* Q8: the paper's Fresnel curve 0.1 + 0.9 (1 - cos)^3 */     \
    X(glass_partial_shadow, 9)      /* Q9: glass casts partial shadows */                         \
    X(pixel_centre_rays, 10)        /* Q10: one ray through each pixel centre */                  \
    X(lit_colour_starts_at_one, 11) /* Q11: the directly lit colour starts at 1, not 0 */         \
    X(no_lambert_cosine, 12) /* Q12: no Lambert cosine: lights behind a surface light it too */   \
    X(no_own_emission, 13)   /* Q13: the hit sphere's own emission is never added */

enum class Quirk {
#define RT_QUIRK_ENUM(name, number) name = number,
    RT_QUIRK_LIST(RT_QUIRK_ENUM)
#undef RT_QUIRK_ENUM
};
#define RT_QUIRK_ONE(name, number) +1
constexpr int kQuirkCount = 0 RT_QUIRK_LIST(RT_QUIRK_ONE);
#undef RT_QUIRK_ONE

// "Q7": the label docs, command lines and EXR headers use.
std::string quirk_label(Quirk q);

// A set of quirks that are *present* (the paper's behaviour). Fixing a quirk removes it.
class QuirkSet {
public:
    static QuirkSet all() {
        QuirkSet s;
        s.bits_.set();
        return s;
    }
    static QuirkSet none() { return {}; }

    bool has(Quirk q) const { return bits_.test(index(q)); }
    void fix(Quirk q) { bits_.reset(index(q)); }
    void add(Quirk q) { bits_.set(index(q)); }
    // "Q1,Q3,..." for the quirks present, "none" when all are fixed.
    std::string present_list() const;

private:
    static std::size_t index(Quirk q) { return static_cast<std::size_t>(q) - 1; }
    std::bitset<kQuirkCount> bits_;
};

enum class Mode { paper, classic, physical };

// paper: every quirk. classic (the scratchapixel program): Q2 fixed without a TIR branch
// (so Q3's NaN can appear), binary shadows = Q4 and Q9 fixed, and its direct light
// (colour from 0, Lambert cosine, the hit sphere's emission added) = Q11, Q12, Q13 fixed.
// physical: none.
QuirkSet quirks_for(Mode mode);
Mode parse_mode(const std::string& text);  // throws std::invalid_argument
const char* mode_name(Mode mode);
// "Q1,Q5" -> {Q1, Q5}; throws std::invalid_argument naming the bad entry.
std::vector<Quirk> parse_quirk_list(const std::string& text);

}  // namespace rt
