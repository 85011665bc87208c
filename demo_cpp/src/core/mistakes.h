// Named common mistakes of a Whitted ray tracer as run-time switches (--mistake NAME), so that
// `rtval diagnose` can render what a program with that mistake shows and `rtval check` can be
// tested against a broken build. The names and explanations live in one file,
// compare/diagnose/mistakes.json, embedded at build time and read by the Python side too: a
// mistake is one row there (the enum below is made from its names) and its code in the tracers.
#pragma once

#include <bitset>
#include <string>
#include <vector>

#include "embedded_mistakes.h"  // RT_MISTAKE_LIST

namespace rt {

enum class Mistake {
#define RT_MISTAKE_ENUM(name) name,
    RT_MISTAKE_LIST(RT_MISTAKE_ENUM)
#undef RT_MISTAKE_ENUM
};
#define RT_MISTAKE_ONE(name) +1
constexpr int kMistakeCount = 0 RT_MISTAKE_LIST(RT_MISTAKE_ONE);
#undef RT_MISTAKE_ONE

class MistakeSet {
public:
    bool has(Mistake m) const { return bits_[static_cast<std::size_t>(m)]; }
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
