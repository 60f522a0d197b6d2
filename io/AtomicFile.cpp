#include "io/AtomicFile.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>

namespace mpm {

void writeAtomically(const std::string& path, const std::function<void(const std::string&)>& write) {
    const std::string tmp = path + ".tmp" + std::to_string(::getpid());
    try {
        write(tmp);
        std::filesystem::rename(tmp, path);
    } catch (...) {
        std::error_code ec;
        std::filesystem::remove(tmp, ec);
        throw;
    }
}

void writeTextAtomically(const std::string& path, const std::string& text) {
    writeAtomically(path, [&](const std::string& tmp) {
        std::ofstream out(tmp, std::ios::binary);
        out << text;
        out.flush();
        if (!out) throw std::runtime_error(path + ": write failed");
    });
}

}  // namespace mpm
