#include "cli/cli_args.h"

#include <cmath>
#include <cstdio>

namespace rt {

int parse_int_arg(const std::string& option, const std::string& text, int lo, int hi) {
    return static_cast<int>(parse_long_arg(option, text, lo, hi));
}

long long parse_long_arg(const std::string& option, const std::string& text, long long lo,
                         long long hi) {
    const std::string rule = "an integer from " + std::to_string(lo) + " to " + std::to_string(hi);
    long long v = 0;
    std::size_t used = 0;
    try {
        v = std::stoll(text, &used);
    } catch (const std::exception&) {
        throw UsageError(option + ": expected " + rule + ", got '" + text + "'");
    }
    if (used != text.size() || v < lo || v > hi)
        throw UsageError(option + ": expected " + rule + ", got '" + text + "'");
    return v;
}

float parse_float_arg(const std::string& option, const std::string& text, float lo, float hi) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "a number from %g to %g", lo, hi);
    const std::string rule = buf;
    float v = 0;
    std::size_t used = 0;
    try {
        v = std::stof(text, &used);
    } catch (const std::exception&) {
        throw UsageError(option + ": expected " + rule + ", got '" + text + "'");
    }
    if (used != text.size() || !std::isfinite(v) || v < lo || v > hi)
        throw UsageError(option + ": expected " + rule + ", got '" + text + "'");
    return v;
}

}  // namespace rt
