// The paper's quirks Q1-Q13 (docs/paper-model.md) as switches, and the three modes as presets.
#pragma once

#include <bitset>
#include <string>
#include <vector>

namespace rt {

enum class Quirk { Q1 = 1, Q2, Q3, Q4, Q5, Q6, Q7, Q8, Q9, Q10, Q11, Q12, Q13 };
constexpr int kQuirkCount = 13;

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
