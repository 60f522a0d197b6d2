#pragma once
// Running the mpm program as a user does, and comparing what two runs wrote (the safety and rank tests).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace mpm::test {

namespace fs = std::filesystem;

inline std::string tempDir(const std::string& name) {
    const fs::path p = fs::temp_directory_path() / ("mpm_test_" + name + "_" + std::to_string(::getpid()));
    fs::remove_all(p);
    fs::create_directories(p);
    return p.string();
}

inline std::string writeFile(const std::string& path, const std::string& text) {
    std::ofstream(path, std::ios::binary) << text;
    return path;
}

inline std::string readFile(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

/// The mpm program started in the background, its output to a log file.
struct Child {
    pid_t pid = -1;
    std::string log;
    int wait() {
        int status = 0;
        ::waitpid(pid, &status, 0);
        return WIFEXITED(status) ? WEXITSTATUS(status) : WIFSIGNALED(status) ? 128 + WTERMSIG(status) : -1;
    }
    std::string output() const { return readFile(log); }
};

/// Starts `program` (the mpm program unless said otherwise, or a launcher such as mpirun) with args.
inline Child start(const std::vector<std::string>& args, const std::string& log, const char* program = MPM_BINARY) {
    Child c;
    c.log = log;
    c.pid = ::fork();
    if (c.pid == 0) {
        const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        ::dup2(fd, 1);
        ::dup2(fd, 2);
        std::vector<char*> argv{const_cast<char*>(program)};
        for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
        argv.push_back(nullptr);
        ::execv(program, argv.data());
        ::_exit(127);
    }
    return c;
}

struct Result {
    int code;
    std::string output;
};

inline Result runMpm(const std::vector<std::string>& args, const std::string& dir) {
    Child c = start(args, dir + "/mpm.log");
    const int code = c.wait();
    return {code, c.output()};
}

/// OpenVDB writes a random archive UUID (36 characters at byte 21) into every file: the rest must match.
inline std::string vdbWithoutUuid(const std::string& path) {
    std::string b = readFile(path);
    constexpr std::size_t kUuidAt = 21, kUuidLength = 36;
    if (b.size() > kUuidAt + kUuidLength) b.replace(kUuidAt, kUuidLength, kUuidLength, '-');
    return b;
}

/// The cells of one line of stats.csv (numbers and names without commas: no quoting).
inline std::vector<std::string> csvCells(const std::string& line) {
    std::vector<std::string> c;
    std::istringstream l(line);
    for (std::string cell; std::getline(l, cell, ',');) c.push_back(cell);
    if (!line.empty() && line.back() == ',') c.emplace_back();
    return c;
}

/// One column of a stats.csv by its header's name, a cell per row; empty when the header has no such column.
inline std::vector<std::string> statsColumn(const std::string& path, const std::string& name) {
    std::istringstream in(readFile(path));
    std::string line;
    std::getline(in, line);
    const std::vector<std::string> names = csvCells(line);
    const std::size_t k = std::size_t(std::find(names.begin(), names.end(), name) - names.begin());
    std::vector<std::string> column;
    if (k == names.size()) return column;
    while (std::getline(in, line))
        if (const std::vector<std::string> row = csvCells(line); k < row.size()) column.push_back(row[k]);
    return column;
}

/// stats.csv without the wall_seconds column (the last one).
inline std::string statsWithoutWallTime(const std::string& path) {
    std::istringstream in(readFile(path));
    std::string out, header;
    std::getline(in, header);
    // The column by its name: rigid bodies' columns follow it.
    const std::vector<std::string> names = csvCells(header);
    const std::size_t wall = std::size_t(std::find(names.begin(), names.end(), "wall_seconds") - names.begin());
    const auto without = [&](const std::string& line) {
        std::vector<std::string> c = csvCells(line);
        if (wall < c.size()) c.erase(c.begin() + std::ptrdiff_t(wall));
        std::string kept;
        for (std::size_t i = 0; i < c.size(); ++i) kept += (i ? "," : "") + c[i];
        return kept + "\n";
    };
    out += without(header);
    for (std::string line; std::getline(in, line);) out += without(line);
    return out;
}

/// Frames, PLY files and stats of two output directories are the same (UUID and wall time aside).
inline void expectSameOutput(const std::string& a, const std::string& b, const std::string& scene, int atLeast = 21) {
    int compared = 0;
    for (const auto& e : fs::directory_iterator(a)) {
        const std::string name = e.path().filename().string();
        const std::string other = b + "/" + name;
        if (name.rfind(scene + "_", 0) != 0 || name.find("checkpoint") != std::string::npos) continue;
        ASSERT_TRUE(fs::exists(other)) << other;
        if (e.path().extension() == ".vdb")
            EXPECT_EQ(vdbWithoutUuid(e.path().string()), vdbWithoutUuid(other)) << name;
        else
            EXPECT_EQ(readFile(e.path().string()), readFile(other)) << name;
        ++compared;
    }
    EXPECT_GE(compared, atLeast);
    EXPECT_EQ(statsWithoutWallTime(a + "/stats.csv"), statsWithoutWallTime(b + "/stats.csv"));
}

}  // namespace mpm::test
