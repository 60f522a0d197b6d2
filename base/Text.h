#pragma once
// Small text helpers the messages and references share.
#include <charconv>
#include <cstdlib>
#include <string>
#include <vector>

namespace mpm {

/// "a, b, c": the names of a list, for messages that say what is allowed.
inline std::string joinNames(const std::vector<std::string>& names, const char* separator = ", ") {
    std::string out;
    for (std::size_t i = 0; i < names.size(); ++i) out += (i ? separator : "") + names[i];
    return out;
}

/// A float as the double of its shortest decimal (0.15f -> 0.15, where double(0.15f) is 0.15000000596046448): how
/// a resolved scene writes a value held as a float, as a user would write it. It reads back to the same float.
inline double shortestDecimal(float value) {
    char text[32];
    const auto end = std::to_chars(text, text + sizeof(text) - 1, value).ptr;
    *end = '\0';
    return std::strtod(text, nullptr);
}

}  // namespace mpm
