// Strict parsing of command-line values: the whole text must be a number in range, or a word
// its parser knows; a failure is a UsageError naming the option and the value.
#pragma once

#include <stdexcept>
#include <string>

namespace rt {

class UsageError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

int parse_int_arg(const std::string& option, const std::string& text, int lo, int hi);
long long parse_long_arg(const std::string& option, const std::string& text, long long lo,
                         long long hi);
// A finite decimal number from lo to hi.
float parse_float_arg(const std::string& option, const std::string& text, float lo, float hi);

// `parse(text)` for the value of `option`. The parsers throw std::invalid_argument saying what
// they expected and what they got ("unknown mode 'x' ..."); that becomes "OPTION: <what>".
template <typename Parse>
auto parse_option(const std::string& option, const std::string& text, Parse parse)
    -> decltype(parse(text)) {
    try {
        return parse(text);
    } catch (const std::invalid_argument& e) {
        throw UsageError(option + ": " + e.what());
    }
}

}  // namespace rt
