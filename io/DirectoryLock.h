#pragma once
// One run per output directory: an advisory lock (flock) on DIR/.mpm.lock, held for the run's life and
// released by the kernel when the process ends, however it ends. The file holds the holder's pid, host and
// start time, so that a second run can say who has the directory; a lock file left by a process that is
// gone is taken over.
#include <stdexcept>
#include <string>

namespace mpm {

/// The directory is in use by another live run. what() names the directory, the pid and the host.
class LockError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

class DirectoryLock {
public:
    /// Takes the lock. Throws LockError when another process holds it, WriteError when the file cannot be made.
    explicit DirectoryLock(const std::string& directory);
    /// Releases it and removes the lock file.
    ~DirectoryLock();
    DirectoryLock(const DirectoryLock&) = delete;
    DirectoryLock& operator=(const DirectoryLock&) = delete;

    /// Who held the lock before, when the lock file was left by a process that is gone (empty otherwise).
    const std::string& takenOverFrom() const { return previous_; }
    const std::string& path() const { return path_; }
    /// Removes the lock file this process holds, if any: for a signal handler that ends the process at once (a
    /// second Ctrl-C), so that no lock is left behind to be taken over. Async-signal-safe.
    static void removeHeldLockFile() noexcept;

private:
    std::string path_, previous_;
    int fd_ = -1;
};

}  // namespace mpm
