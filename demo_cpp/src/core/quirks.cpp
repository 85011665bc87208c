#include "core/quirks.h"

#include <sstream>
#include <stdexcept>

namespace rt {

std::string quirk_label(Quirk q) { return "Q" + std::to_string(static_cast<int>(q)); }

std::string QuirkSet::present_list() const {
    std::string out;
    for (int i = 1; i <= kQuirkCount; ++i)
        if (has(static_cast<Quirk>(i))) out += (out.empty() ? "Q" : ",Q") + std::to_string(i);
    return out.empty() ? "none" : out;
}

QuirkSet quirks_for(Mode mode) {
    QuirkSet s = QuirkSet::all();
    switch (mode) {
        case Mode::paper:
            break;
        case Mode::classic:
            s.fix(Quirk::eta_one_over_ior_leaving);
            s.fix(Quirk::shared_shadow_factor);
            s.fix(Quirk::glass_partial_shadow);
            s.fix(Quirk::lit_colour_starts_at_one);
            s.fix(Quirk::no_lambert_cosine);
            s.fix(Quirk::no_own_emission);
            break;
        case Mode::physical:
            s = QuirkSet::none();
            break;
    }
    return s;
}

Mode parse_mode(const std::string& text) {
    if (text == "paper") return Mode::paper;
    if (text == "classic") return Mode::classic;
    if (text == "physical") return Mode::physical;
    throw std::invalid_argument("unknown mode '" + text +
                                "' (expected paper, classic or physical)");
}

const char* mode_name(Mode mode) {
    switch (mode) {
        case Mode::paper:
            return "paper";
        case Mode::classic:
            return "classic";
        case Mode::physical:
            return "physical";
    }
    return "?";
}

std::vector<Quirk> parse_quirk_list(const std::string& text) {
    std::vector<Quirk> out;
    std::stringstream ss(text);
    std::string item;
    while (std::getline(ss, item, ',')) {
        std::size_t used = 0;
        int n = 0;
        bool ok = item.size() >= 2 && (item[0] == 'Q' || item[0] == 'q');
        if (ok) {
            try {
                n = std::stoi(item.substr(1), &used);
            } catch (const std::exception&) {
                ok = false;
            }
        }
        if (!ok || used != item.size() - 1 || n < 1 || n > kQuirkCount)
            throw std::invalid_argument("unknown quirk '" + item + "' (expected Q1 ... Q13)");
        out.push_back(static_cast<Quirk>(n));
    }
    if (out.empty()) throw std::invalid_argument("empty quirk list (expected e.g. Q1,Q5)");
    return out;
}

}  // namespace rt
