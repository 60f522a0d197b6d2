#pragma once
// What benchmark and report output names the machine by.
#include <fstream>
#include <string>

namespace mpm::bench {

/// The CPU model from /proc/cpuinfo ("unknown CPU" elsewhere).
inline std::string cpuModel() {
    std::ifstream in("/proc/cpuinfo");
    for (std::string line; std::getline(in, line);)
        if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
    return "unknown CPU";
}

}  // namespace mpm::bench
