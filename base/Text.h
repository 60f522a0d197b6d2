#pragma once
// Small text helpers the messages and references share.
#include <string>
#include <vector>

namespace mpm {

/// "a, b, c": the names of a list, for messages that say what is allowed.
inline std::string joinNames(const std::vector<std::string>& names, const char* separator = ", ") {
    std::string out;
    for (std::size_t i = 0; i < names.size(); ++i) out += (i ? separator : "") + names[i];
    return out;
}

}  // namespace mpm
