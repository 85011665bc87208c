// Strict parsing of command-line values: the whole text must be a number in range.
#pragma once

#include <stdexcept>
#include <string>

namespace rt {

class UsageError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

int parse_int_arg(const std::string& option, const std::string& text, int lo, int hi);

}  // namespace rt
