#include "io/DirectoryLock.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <ctime>

#include "io/AtomicFile.h"

namespace mpm {

namespace {
std::string readAll(int fd) {
    std::string s;
    char buf[512];
    ::lseek(fd, 0, SEEK_SET);
    for (ssize_t n; (n = ::read(fd, buf, sizeof buf)) > 0;) s.append(buf, std::size_t(n));
    while (!s.empty() && (s.back() == '\n' || s.back() == '\0')) s.pop_back();
    return s;
}

/// The lock file this process holds, for a signal handler to remove (empty: none). A fixed buffer: the handler may
/// call nothing that allocates.
constexpr std::size_t kLivePathSize = 4096;
char gLivePath[kLivePathSize] = {};

std::string hostName() {
    char host[256] = {};
    ::gethostname(host, sizeof host - 1);
    return host;
}
}  // namespace

DirectoryLock::DirectoryLock(const std::string& directory) : path_(directory + "/.mpm.lock") {
    // A holder that finishes unlinks the file: a lock taken on the unlinked file would protect nothing, so
    // the lock counts only if the path still names the file locked.
    constexpr int kAttempts = 8;
    for (int attempt = 0; fd_ < 0; ++attempt) {
        fd_ = ::open(path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
        if (fd_ < 0) throw WriteError(path_, std::string("cannot create the lock file: ") + std::strerror(errno));
        if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
            const int e = errno;
            const std::string holder = readAll(fd_);
            ::close(fd_);
            fd_ = -1;
            if (e == EWOULDBLOCK)
                throw LockError(directory + ": in use by another run (" + (holder.empty() ? "holder unknown" : holder) +
                                "); wait for it to finish, or give another directory with -o");
            throw LockError(directory + ": cannot lock " + path_ + ": " + std::strerror(e));
        }
        struct stat held {
        }, named{};
        if (::fstat(fd_, &held) == 0 && ::stat(path_.c_str(), &named) == 0 && held.st_ino == named.st_ino &&
            held.st_dev == named.st_dev)
            break;
        ::close(fd_);
        fd_ = -1;
        if (attempt + 1 == kAttempts) throw LockError(directory + ": the lock file keeps changing under this run");
    }
    // We hold it: whatever the file says is from a process that is gone.
    previous_ = readAll(fd_);
    const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
    char when[64];
    std::strftime(when, sizeof when, "%Y-%m-%d %H:%M:%S", std::localtime(&now));
    const std::string me = "pid " + std::to_string(::getpid()) + " on host " + hostName() + " since " + when + "\n";
    if (::ftruncate(fd_, 0) != 0 || ::pwrite(fd_, me.data(), me.size(), 0) != ssize_t(me.size()))
        throw WriteError(path_, std::string("cannot write the lock file: ") + std::strerror(errno));
    if (path_.size() < kLivePathSize) std::memcpy(gLivePath, path_.c_str(), path_.size() + 1);
}

void DirectoryLock::removeHeldLockFile() noexcept {
    if (gLivePath[0] != '\0') ::unlink(gLivePath);  // async-signal-safe
}

DirectoryLock::~DirectoryLock() {
    if (fd_ < 0) return;
    gLivePath[0] = '\0';
    ::unlink(path_.c_str());  // while still holding it, so no one else's lock is removed
    ::close(fd_);
}

}  // namespace mpm
