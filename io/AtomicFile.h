#pragma once
// Files appear whole or not at all: each is written under a temporary name in its final directory, every
// write is checked, the data is flushed to the disk (fsync) and only then renamed into place, and the
// directory entry is synced too. A failed or short write (a full disk, a lost mount) removes the temporary
// file, leaves any earlier file of that name as it was, and throws WriteError naming the file and the
// system's reason.
#include <functional>
#include <memory>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

namespace mpm {

/// A write that did not complete. what() reads "PATH: REASON" (for example "No space left on device").
class WriteError : public std::runtime_error {
public:
    WriteError(const std::string& path, const std::string& reason) : std::runtime_error(path + ": " + reason), path_(path) {}
    const std::string& path() const { return path_; }

private:
    std::string path_;
};

/// The temporary name of `path` while this process writes it: "<path>.tmp<pid>".
std::string temporaryPathOf(const std::string& path);
/// Whether `name` (a file name, no directory) is some process's temporary file of the final name `finalName`.
bool isTemporaryOf(const std::string& name, const std::string& finalName);

class AtomicFile {
public:
    /// Creates the temporary file. Throws WriteError when it cannot.
    explicit AtomicFile(std::string path);
    /// Removes the temporary file unless commit() succeeded.
    ~AtomicFile();
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;

    /// Where to write; every write through it is checked.
    std::ostream& stream();
    /// Flushes, checks, syncs and renames the file into place. Throws WriteError.
    void commit();
    const std::string& path() const { return path_; }

private:
    class Buffer;
    [[noreturn]] void failWith(int error);
    std::string path_, tmp_;
    int fd_ = -1;
    std::unique_ptr<Buffer> buffer_;
    std::unique_ptr<std::ostream> stream_;
    bool committed_ = false;
};

/// Calls write(stream) on an AtomicFile for path, then commits it.
void writeAtomically(const std::string& path, const std::function<void(std::ostream&)>& write);

/// Convenience: the whole text content at once.
void writeTextAtomically(const std::string& path, const std::string& text);

}  // namespace mpm
